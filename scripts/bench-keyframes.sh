#!/usr/bin/env bash
# Benchmark of key frames only (`[video] frames = "keyframes"`) against every frame, both
# measured in the same run on this machine: a 10 s 1080p30 H.264 steady hold at ~40 Mb/s
# with a key frame every 15 frames (half a second, as action cameras record), decoded
# and measured (detection, marker order, circle per frame) by examples/bench_keyframes.rs
# every frame and key frames only, best of 3 each. Prints the video frames covered per
# second of each, the throughput ratio and the relative difference of the median radii.
# PROFILE=test uses the test profile's build (opt-level 2) instead of release.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=${PROFILE:-release}
cargo build --profile "$profile" --locked --example bench_keyframes
case "$profile" in dev | test) sub=debug ;; *) sub=$profile ;; esac
"${CARGO_TARGET_DIR:-target}/$sub/examples/bench_keyframes" target/bench/keyframes 1920 1080 300 15 40
