#!/usr/bin/env bash
# Regenerates fixtures/bags (deterministic): RealSense-layout ROS1 bags written by an
# independent writer (the `rosbags` Python package) from an RGB-D session that bendscope
# renders, for tests/bag.rs:
#   fixtures/bags/png/       the rendered PNG session (9 frames: 3 FEM pressures x 3)
#   fixtures/bags/lz4/       the same frames as recording.bag, lz4 chunks
#   fixtures/bags/bz2/       the same, bz2 chunks
#   fixtures/bags/baseline/  a depth camera of its own (15 mm baseline), depth computed
#                            for its view of the scene plane; truth.json
#   fixtures/bags/nodepth/   colour only
# Only this script needs rosbags (installed into a venv, BAG_VENV, default
# $CARGO_TARGET_DIR/bagvenv or target/bagvenv); the cargo tests read the committed files.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
venv="${BAG_VENV:-$target/bagvenv}"
# The test profile (opt-level 2, as `cargo test` builds it): the FEM and the render take
# seconds there, minutes unoptimized.
cargo build --quiet --locked --profile test --bin bendscope
bendscope="$target/debug/bendscope"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet 'rosbags==0.11.9' 'numpy>=1.24' 'pillow>=10'
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The FEM of the reference actuator at 3 pressures, rendered: the RGB-D part is a 640x480
# pinhole camera at 260 mm, the plane tilted 15 degrees, 3 frames per pressure, 10 fps
# (the video part is kept tiny: it is not used).
"$bendscope" simulate --mesh-size 3 --pressures 30:110:40 --no-vtu -o "$work/fem" >/dev/null
"$bendscope" render --fem "$work/fem" --gopro-like 320x240 --frames 1 --calib-views 0 \
    --supersample 1 --clean --rgbd -o "$work/session" >/dev/null
rm -rf fixtures/bags
mkdir -p fixtures/bags
cp -r "$work/session/rgbd" fixtures/bags/png
"$venv/bin/python" scripts/make-bag-fixtures.py fixtures/bags/png fixtures/bags
du -sh fixtures/bags
