#!/usr/bin/env bash
# Set-up, then the main job on the shipped example: calibrate the GoPro-like fisheye
# camera from fixtures/fisheye/calib and measure the scale from fixtures/fisheye/scale.jpg.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
bin=target/release/bendscope
out=${1:-bendscope-out/example}
mkdir -p "$out"
"$bin" calibrate fixtures/fisheye/calib --board 9x6 --square-mm 25 --model fisheye -o "$out/gopro.yaml"
"$bin" scale fixtures/fisheye/scale.jpg --calibration "$out/gopro.yaml" --board 9x6 --square-mm 25 --save "$out/scale.json"
echo "calibration: $out/gopro.yaml   scale: $out/scale.json   (ground truth: fixtures/fisheye/truth.json)"
