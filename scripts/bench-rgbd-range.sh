#!/usr/bin/env bash
# RGB-D at long radii (issue 40, item 6): the reference actuator without gravity at 4, 6, 10
# and 20 kPa (radii 843 / 565 / 342 / 175 mm at a 3 mm mesh), rendered as an RGB-D session
# (`bendscope render --rgbd`: 640x480 pinhole colour, depth with noise, plane tilted 15
# degrees, 3 frames per pressure), written as RealSense bags by scripts/make-bag-fixtures.py
# (the `rosbags` package in a venv: a depth camera of its own with a 15 mm baseline), then
# measured from the PNG folder and from the baseline bag. Prints each frame's radius error
# against the rendered truth and the largest per frame. A minute or two on 2 cores.
# BENDSCOPE=path skips the build; OUT (default target/bench/rgbd-range) holds the runs.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
if [ -z "${BENDSCOPE:-}" ]; then
  cargo build --quiet --locked --profile test --bin bendscope
  BENDSCOPE="$target/debug/bendscope"
fi
venv="${BAG_VENV:-$target/bagvenv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet 'rosbags==0.11.9' 'numpy>=1.24' 'pillow>=10'
out=${OUT:-target/bench/rgbd-range}
rm -rf "$out"
mkdir -p "$out"
"$BENDSCOPE" simulate --mesh-size 3 --pressures 4,6,10,20 --no-gravity --no-vtu -o "$out/fem" >"$out/fem.log" 2>&1
"$BENDSCOPE" render --fem "$out/fem" --gopro-like 320x240 --frames 1 --calib-views 0 \
  --supersample 1 --rgbd -o "$out/session" >"$out/render.log" 2>&1
"$venv/bin/python" scripts/make-bag-fixtures.py "$out/session/rgbd" "$out/bags" >"$out/bags.log" 2>&1
"$BENDSCOPE" process "$out/session/rgbd" -o "$out/out-png" >"$out/png.log" 2>&1
"$BENDSCOPE" process "$out/bags/baseline" -o "$out/out-baseline" >"$out/baseline.log" 2>&1
python3 - "$out" <<'PY'
import csv, json, sys
out = sys.argv[1]
truth = {t["pressure_kpa"]: t["radius_mm"] for t in json.load(open(f"{out}/session/rgbd/truth.json"))}
for label in ("png", "baseline"):
    worst = 0.0
    print(f"{label}: per-frame radius error, %")
    for r in csv.DictReader(open(f"{out}/out-{label}/per_frame.csv")):
        p = float(r["pressure_kpa"])
        t = min(truth, key=lambda k: abs(k - p))
        if abs(t - p) > 0.5 or not r["radius_mm"]:
            continue
        e = 100 * (float(r["radius_mm"]) / truth[t] - 1)
        worst = max(worst, abs(e))
        print(f"  {p:5.1f} kPa  truth {truth[t]:7.2f} mm  measured {float(r['radius_mm']):7.2f} mm  {e:+6.2f}%")
    print(f"{label}: largest per-frame error {worst:.2f}% (goal 1.5%)")
PY
