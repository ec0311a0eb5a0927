#!/usr/bin/env bash
# Set-up, then the main job on the shipped example session: five videos of a synthetic
# actuator filmed through a GoPro-like fisheye camera at 20..80 kPa, with calib/ photos,
# a scale photo and ground truth (fixtures/sessions/example/truth.json).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
out=${1:-bendscope-out/example}
target/release/bendscope process fixtures/sessions/example -o "$out" --force
echo
echo "results in $out:"
echo "  per_video.csv  radius_mm, curvature_per_m, bending_angle_deg per pressure"
echo "  per_frame.csv  every frame's measurement or rejection reason"
echo "  fit.json       power law y = a x^b + c of radius and curvature vs pressure"
echo "  plots/         radius, curvature, angle vs pressure; radius per frame (PNG, SVG, PDF)"
echo "  overlays/      one undistorted frame per video with what was measured"
echo "  report.html    the whole session on one page (open it in a browser)"
echo "ground truth:    fixtures/sessions/example/truth.json"
if command -v column > /dev/null; then column -s, -t < "$out/per_video.csv" | cut -c1-140; else cat "$out/per_video.csv"; fi
