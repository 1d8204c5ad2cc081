# Shared by the end-to-end bench scripts (sourced): the release build, its
# binary in $bin, $threads (THREADS, default 2), the scratch folder $out
# (created) and, in it, drop_corner_1.toml (drop_corner up to its first
# impact).
# usage: source benches/lib.sh SCRATCH_DIR
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=$1
threads=${THREADS:-2}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/impactmc
sed 's/^bounces = 5$/bounces = 1/' configs/drop_corner.toml > "$out/drop_corner_1.toml"
grep -q '^bounces = 1$' "$out/drop_corner_1.toml"
