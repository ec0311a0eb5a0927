#!/usr/bin/env bash
# Idempotent set-up: installs the Debian packages the build needs when missing, then builds.
# Usage: scripts/setup.sh [--no-build]
set -euo pipefail
cd "$(dirname "$0")/.."

PKGS=(
  pkg-config clang libclang-dev
  libopencv-dev
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev libswresample-dev ffmpeg
  libfontconfig1-dev fonts-dejavu-core
  parallel
  socat
  chromium
  python3-venv python3-pip
  calculix-ccx
  gmsh
)

scripts/apt-need.sh setup "${PKGS[@]}"

if [ "${1:-}" != "--no-build" ]; then
  cargo build --release --locked --bin bendscope
fi
