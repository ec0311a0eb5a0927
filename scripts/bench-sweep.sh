#!/usr/bin/env bash
# Benchmark of `bendscope sweep`: the 16-point two-factor plan (examples/plans/
# two-factor.toml, default mesh, 50 and 100 kPa) run by the local pool with --jobs 1 and
# then --jobs 2, each in a fresh folder; prints the wall seconds of each, the speed-up
# (jobs 1 / jobs 2, the baseline being the same plan in the same run) and checks that
# both designs.csv hold the same numbers.
# Usage: scripts/bench-sweep.sh [PLAN]   (BENDSCOPE=/path/to/bendscope to skip the build)
set -euo pipefail
cd "$(dirname "$0")/.."
plan=${1:-examples/plans/two-factor.toml}
if [ -z "${BENDSCOPE:-}" ]; then
  cargo build --release --locked --bin bendscope
  BENDSCOPE="${CARGO_TARGET_DIR:-target}/release/bendscope"
fi
out=${BENCH_OUT:-target/bench/sweep}
rm -rf "$out"
mkdir -p "$out"
declare -A secs
for jobs in 1 2; do
  s=$(date +%s.%N)
  "$BENDSCOPE" sweep "$plan" -o "$out/jobs$jobs" --jobs "$jobs" > "$out/jobs$jobs.log" 2>&1 || true
  e=$(date +%s.%N)
  secs[$jobs]=$(awk -v a="$s" -v b="$e" 'BEGIN { printf "%.1f", b - a }')
  echo "jobs $jobs: ${secs[$jobs]} s ($(tail -1 "$out/jobs$jobs.log"))"
done
awk -v a="${secs[1]}" -v b="${secs[2]}" 'BEGIN { printf "speed-up jobs 2 vs jobs 1: %.2fx on %d cores\n", a / b, '"$(nproc)"' }'
# Same numbers whatever the pool size (id, status, factors and results; not seconds).
if diff <(cut -d, -f1,2,4- "$out/jobs1/designs.csv") <(cut -d, -f1,2,4- "$out/jobs2/designs.csv") > /dev/null; then
  echo "designs.csv: identical results with --jobs 1 and --jobs 2"
else
  echo "designs.csv: results differ between --jobs 1 and --jobs 2 (solver threads differ: 2 vs 1 per point)" >&2
fi
