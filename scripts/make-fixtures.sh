#!/usr/bin/env bash
# Regenerates the synthetic fixtures (deterministic): fixtures/fisheye = 20 checkerboard
# photos through a GoPro-like fisheye camera (960x720), a scale photo and truth.json.
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf fixtures/fisheye
cargo run --quiet --locked --example make_fixtures -- fixtures/fisheye 960 20
