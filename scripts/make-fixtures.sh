#!/usr/bin/env bash
# Regenerates the synthetic fixtures (deterministic):
# - fixtures/fisheye: 20 checkerboard photos through a GoPro-like fisheye camera
#   (960x720), a scale photo and truth.json;
# - fixtures/sessions/example: a session (5 pressures, 8-frame 800x600 H.264 videos,
#   calib/, scale.jpg, pressures.csv, bendscope.toml, truth.json).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet --locked --release --example make_fixtures --example make_session
rm -rf fixtures/fisheye fixtures/sessions/example
target/release/examples/make_fixtures fixtures/fisheye 960 20
target/release/examples/make_session fixtures/sessions/example 800 8
