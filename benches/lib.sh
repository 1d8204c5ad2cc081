# Shared by the end-to-end bench scripts (sourced): the release build, its
# binary in $bin, $threads (THREADS, default 2), the scratch folder $out
# (created) and, in it, corner3_mu03.toml: S3 with μ = 0.3 on every wall.
# usage: source benches/lib.sh SCRATCH_DIR
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=$1
threads=${THREADS:-2}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/impactmc
sed 's/^restitution = \(.*\)$/restitution = \1\nfriction = 0.3/' configs/corner3.toml \
    > "$out/corner3_mu03.toml"
