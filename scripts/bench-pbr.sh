#!/usr/bin/env bash
# Physically based test footage (issue 40, item 2): renders a PneuNets-like actuator with
# Mitsuba 3 through a GoPro-like fisheye (scripts/pbr/render_session.py, in a venv under
# target/pbr-venv; renders cached in target/pbr/pbr-cache, so a rerun only measures),
# measures it with the release bendscope and prints truth vs measured radius per pressure.
# Extra runs isolate the causes of the error: the true lens given as the calibration.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/pbr-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q -r scripts/pbr/requirements.txt
fi
cargo build --release --locked --bin bendscope
session=target/pbr/session
nice "$venv/bin/python" scripts/pbr/render_session.py "$session"
bs=target/release/bendscope
"$bs" process "$session" -o target/pbr/out --force > target/pbr/out.log 2>&1 || true
"$venv/bin/python" scripts/pbr/compare.py "$session" target/pbr/out --label "calibrated from the rendered calib/ photos"
"$bs" process "$session" -o target/pbr/out-truelens --calibration "$session/true-calibration.yaml" --force \
  > target/pbr/out-truelens.log 2>&1 || true
"$venv/bin/python" scripts/pbr/compare.py "$session" target/pbr/out-truelens --label "the true lens given as the calibration"
