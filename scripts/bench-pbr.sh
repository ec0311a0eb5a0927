#!/usr/bin/env bash
# Physically based test footage (issue 40, item 2): renders a PneuNets-like actuator with
# Mitsuba 3 through a GoPro-like fisheye (scripts/pbr/render_session.py, in a venv under
# target/pbr-venv; renders cached in target/pbr/pbr-cache, so a rerun only encodes and
# measures), measures it with the release bendscope and prints truth vs measured radius
# per pressure, then the same with the true lens given as the calibration, and the
# centroids' own share (their radius through the true lens onto the true marker plane).
# Each pressure is rendered with 4 sampler seeds cycled over the frames (the renderer's
# noise then varies from frame to frame as a sensor's does); rendering the whole session
# takes about 40 min on 2 shared cores.
# BENDSCOPE=path/to/bendscope skips the build.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/pbr-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q -r scripts/pbr/requirements.txt
fi
if [ -z "${BENDSCOPE:-}" ]; then
  cargo build --release --locked --bin bendscope
  BENDSCOPE=target/release/bendscope
fi
session=target/pbr/session
py="$venv/bin/python"
nice "$py" scripts/pbr/render_session.py "$session" --seeds 4
"$BENDSCOPE" process "$session" -o target/pbr/out --force > target/pbr/out.log 2>&1 || true
"$py" scripts/pbr/compare.py "$session" target/pbr/out --label "calibrated from the rendered calib/ photos"
"$BENDSCOPE" process "$session" -o target/pbr/out-truelens --calibration "$session/true-calibration.yaml" \
  --force > target/pbr/out-truelens.log 2>&1 || true
"$py" scripts/pbr/compare.py "$session" target/pbr/out-truelens --label "the true lens given as the calibration"
echo "## the centroids alone (true lens, true marker plane)"
"$py" scripts/pbr/decompose.py "$session" target/pbr/out-truelens
