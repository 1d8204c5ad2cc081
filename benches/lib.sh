# Shared by the end-to-end bench scripts (sourced): the release build, its
# binary in $bin, $threads (THREADS, default 2), the scratch folder $out
# (created) and, in it, drop_corner_1.toml (drop_corner up to its first
# impact); describe_machine sets $cpu, $simd, $version and $commit for a
# table's heading.
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

# The machine and build a table was measured on: $cpu (model, family and
# model numbers), $simd (the SIMD flags that choose the lanes), $version
# and $commit.
describe_machine() {
    field() { grep -m1 "^$1" /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//'; }
    cpu="$(field 'model name'), family $(field 'cpu family') model $(field 'model')"
    simd=$(grep -m1 '^flags' /proc/cpuinfo | tr ' ' '\n' | grep -E '^(avx2|fma|avx512f|avx512vl|avx512bw|avx512dq)$' | sort | paste -sd ' ' -)
    version=$("$bin" --version | cut -d' ' -f2)
    commit=$(git rev-parse --short HEAD 2> /dev/null || echo unknown)
}
