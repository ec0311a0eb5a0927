#!/usr/bin/env bash
# Outline mode against the dots on a FEM render (issue 40, item 4): the reference PneuNets
# with a paper-like strain-limiting layer (0.1 mm, 3 GPa) at a 4 mm mesh, gravity off,
# 20/50/80 kPa, rendered by `bendscope render --fem` through the GoPro-like fisheye at
# 1920x1080 from 170 mm, once with its dots and once bare; the dots measured in dots mode,
# the bare body in outline mode with the dot line's height (14 mm) as the offset. Prints
# per pressure the dots' and the outline's median radius, the outline's
# difference and its curvature difference, then the two sessions' process times (the same binary, the same
# calibration). About 5 minutes on 2 shared cores. BENDSCOPE=path skips the build; OUT
# (default target/bench/outline-fem) holds the runs.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${BENDSCOPE:-}" ]; then
  cargo build --release --locked --bin bendscope
  BENDSCOPE=target/release/bendscope
fi
out=${OUT:-target/bench/outline-fem}
rm -rf "$out"
mkdir -p "$out"
cat >"$out/actuator.toml" <<'TOML'
[geometry]
family = "pneunets"
[mesh]
size_mm = 4
[load]
gravity = false
pressures_kpa = "20,50,80"
[layer]
thickness_mm = 0.1
youngs_modulus_mpa = 3000
TOML
"$BENDSCOPE" simulate --config "$out/actuator.toml" -o "$out/sim" --no-vtu >"$out/sim.log" 2>&1
for s in dots bare; do
  extra=()
  [ "$s" = bare ] && extra=(--no-dots)
  "$BENDSCOPE" render --fem "$out/sim" --gopro-like 1920x1080 --distance-mm 170 -o "$out/$s" \
    --frames 3 --calib-views 10 "${extra[@]}" >"$out/render-$s.log" 2>&1
done
printf '\n[detect]\nmode = "outline"\noutline_offset_mm = 14\n' >>"$out/bare/bendscope.toml"
"$BENDSCOPE" process "$out/dots" -o "$out/dots-out" >"$out/dots.log" 2>&1
cal="$out/dots-out/calibration.yaml"
"$BENDSCOPE" process "$out/bare" -o "$out/bare-out" --calibration "$cal" >"$out/bare.log" 2>&1
python3 - "$out" <<'PY'
import csv, json, sys
out = sys.argv[1]
rows = lambda s: {r["pressure_kpa"]: r for r in csv.DictReader(open(f"{out}/{s}-out/per_video.csv"))}
dots, bare = rows("dots"), rows("bare")
print(f"{'kPa':>6} {'dots mm':>9} {'outline mm':>11} {'vs dots':>8} {'dk 1/m':>7}")
for p, d in dots.items():
    o = bare[p]
    rd, ro = float(d["radius_mm_median"]), float(o["radius_mm_median"])
    print(f"{float(p):6.1f} {rd:9.2f} {ro:11.2f} {100 * (ro / rd - 1):+7.2f}% {1000 / ro - 1000 / rd:+7.3f}")
PY
for s in dots bare; do
  rm -rf "$out/time-$s"
  start=$(date +%s.%N)
  "$BENDSCOPE" process "$out/$s" -o "$out/time-$s" --calibration "$cal" >/dev/null 2>&1
  echo "$s process: $(echo "$(date +%s.%N) - $start" | bc) s (9 frames of 1920x1080)"
done
