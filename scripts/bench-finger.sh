#!/usr/bin/env bash
# The segmented finger (family `segmented-finger`) against the finger-design study's
# published ANSYS bending angles at 90 kPa: its 11 designs (H = 10/15/20/25 mm at N = 12;
# N = 12/14/18/20 at H = 10; TSB = 1/1.25/1.5/1.75 mm at H = 15, N = 14; TOF = 1.25 mm),
# one simulation each with the family's chosen values, the study's Yeoh set and 2 mm
# tetrahedra (SIZE_MM to change). Prints per design the circle-fit bending angle of the
# bottom markers (steps.csv) and the tip angle (the chord of the last two markers turned
# from +x), the study's angle and the tip angle's error. PROFILE=test uses the test
# profile's build (opt-level 2) instead of release; OUT (default target/bench/finger)
# holds each run.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=${PROFILE:-release}
size=${SIZE_MM:-2}
out=${OUT:-target/bench/finger}
cargo build --profile "$profile" --locked --bin bendscope
case "$profile" in dev | test) sub=debug ;; *) sub=$profile ;; esac
bin="${CARGO_TARGET_DIR:-target}/$sub/bendscope"
mkdir -p "$out"
# name H N TSB TOF study_angle_deg
designs="H10 10 12 1 1.25 78.94
H15 15 12 1 1.25 94.43
H20 20 12 1 1.25 102.09
H25 25 12 1 1.25 106.55
N14 10 14 1 1.25 89.30
N18 10 18 1 1.25 106.66
N20 10 20 1 1.25 115.03
T100 15 14 1 1.25 106.45
T125 15 14 1.25 1.25 97.40
T150 15 14 1.5 1.25 92.25
T175 15 14 1.75 1.25 85.72"
printf '%-5s %5s %3s %5s %5s %9s %9s %9s %8s %7s\n' design H N TSB TOF circle tip study error s
while read -r name h n tsb tof study; do
    cfg="$out/$name.toml"
    printf '[geometry]\nfamily = "segmented-finger"\n[finger]\nheight_mm = %s\nbellows = %s\nwall_mm = %s\nfoot_mm = %s\n[mesh]\nsize_mm = %s\n' \
        "$h" "$n" "$tsb" "$tof" "$size" >"$cfg"
    start=$(date +%s.%N)
    "$bin" simulate --config "$cfg" --no-vtu -o "$out/$name" >"$out/$name.log" 2>&1 || true
    secs=$(echo "$(date +%s.%N) - $start" | bc)
    python3 - "$out/$name" "$h" "$n" "$tsb" "$tof" "$study" "$secs" "$name" <<'PY'
import csv, math, sys
d, h, n, tsb, tof, study, secs, name = sys.argv[1:]
try:
    steps = list(csv.DictReader(open(f"{d}/steps.csv")))
    marks = list(csv.DictReader(open(f"{d}/markers.csv")))
except FileNotFoundError:
    print(f"{name:<5} failed: see {d}.log"); sys.exit(0)
last, m = steps[-1], marks[-1]
k = max(int(c[1:].split("_")[0]) for c in m if c.startswith("m") and c.endswith("_x_mm"))
dx = float(m[f"m{k}_x_mm"]) - float(m[f"m{k-1}_x_mm"])
dz = float(m[f"m{k}_z_mm"]) - float(m[f"m{k-1}_z_mm"])
tip = math.degrees(math.atan2(-dz, dx)) % 360
err = (tip / float(study) - 1) * 100
p = float(last["pressure_kpa"])
note = "" if abs(p - 90) < 1e-6 else f" (stopped at {p} kPa)"
print(f"{name:<5} {h:>5} {n:>3} {tsb:>5} {tof:>5} {float(last['bending_angle_deg']):9.2f} {tip:9.2f} {float(study):9.2f} {err:+7.1f}% {float(secs):7.0f}{note}")
PY
done <<<"$designs"
