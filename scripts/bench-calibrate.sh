#!/usr/bin/env bash
# Benchmark: fisheye calibration of 20 synthetic 4000x3000 photos (GoPro still size).
# bendscope (boards searched on a 1280 px copy, refined at full resolution, views in
# parallel) vs a baseline in the same run: sequential (one thread) detection at full
# resolution. Prints seconds and the ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin bendscope --example make_fixtures
data=target/bench/cal4000
if [ ! -f "$data/truth.json" ]; then
  target/release/examples/make_fixtures "$data" 4000 20 1
fi
t() { local s e; s=$(date +%s.%N); "$@" > /dev/null; e=$(date +%s.%N); awk -v a="$s" -v b="$e" 'BEGIN { printf "%.2f", b - a }'; }
fast=$(t target/release/bendscope calibrate "$data/calib" -o target/bench/fast.yaml)
base=$(RAYON_NUM_THREADS=1 t target/release/bendscope calibrate "$data/calib" --detect-px 100000 -o target/bench/base.yaml)
echo "bendscope: ${fast} s   baseline (sequential, full resolution): ${base} s   speed-up: $(awk -v a="$base" -v b="$fast" 'BEGIN { printf "%.2f", a / b }')x"
grep -E "avg_reprojection_error" target/bench/fast.yaml target/bench/base.yaml
