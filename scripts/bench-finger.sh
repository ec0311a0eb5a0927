#!/usr/bin/env bash
# The segmented finger (family `segmented-finger`) against the finger-design study's
# published ANSYS bending angles at 90 kPa: its 11 designs (H = 10/15/20/25 mm at N = 12;
# N = 12/14/18/20 at H = 10; TSB = 1/1.25/1.5/1.75 mm at H = 15, N = 14; TOF = 1.25 mm),
# one simulation each with the study's Yeoh set and 2 mm tetrahedra (SIZE_MM to change).
# Prints per design the circle-fit bending angle of the bottom markers (steps.csv) and the
# tip angle (the chord of the last two markers turned from +x), the study's angle and the
# tip angle's error. PROFILE=test uses the test profile's build (opt-level 2) instead of
# release; OUT (default target/bench/finger) holds each run; DESIGNS (e.g. "H10 H15") runs
# some; PRESSURES (default 15:90:15) is the ramp.
# READING picks how the study's open values are read (docs/src/validation.md, "The
# segmented finger"): `family` (default) the family's chosen values; the others, the
# earlier readings, draw the family's script (examples/geo/segmented_finger.geo) with
# other numbers through `family = "mesh"`: `bellow` alone, `bottom-sheet` with a
# strain-limiting sheet on the bottom face, `outer-sheet` a sheet on the bellows' tops and
# sides, `outer-sheet-ends` also on their end walls. Their numbers:
#   BELLOW_MM  bellows this long whatever N is (default 6; 0: gaps GAP_MM, default 1.5)
#   SHEET_MM, SHEET_MPA  the sheet's thickness and modulus (default 0.5 mm, 1000 MPa)
#   SIDE=1     each bellow's top a half cylinder across the finger (seen from the side),
#              its flat side walls SIDEWALL_MM thick (default 0: TSB)
#   CHANNEL_MM a channel that high joins a segment's bellows (default 0: none), under a
#              roof ROOF_MM thick (default 0: TSB)
#   PITCH_MM   bellows this far apart from the clamp, bare foot beyond (default 0: L / N)
#   CAVITY_MM  each bellow's cavity this long, its walls TSB outside it and GAP_MM between
#              bellows (sets BELLOW_MM and PITCH_MM from TSB); with CAVITY_WIDTH_MM the
#              cavity that wide too, the finger 2 TSB wider (else WIDTH_MM, default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
profile=${PROFILE:-release}
size=${SIZE_MM:-2}
out=${OUT:-target/bench/finger}
reading=${READING:-family}
pressures=${PRESSURES:-15:90:15}
case "$reading" in
family | bellow) sheet=0 ;;
outer-sheet) sheet=1 ;;
outer-sheet-ends) sheet=2 ;;
bottom-sheet) sheet=3 ;;
*) echo "bench-finger: READING=$reading is none of family, bellow, bottom-sheet, outer-sheet, outer-sheet-ends" >&2; exit 2 ;;
esac
cargo build --profile "$profile" --locked --bin bendscope
case "$profile" in dev | test) sub=debug ;; *) sub=$profile ;; esac
bin="${CARGO_TARGET_DIR:-target}/$sub/bendscope"
# The readings take the family's material as the program states it.
material=$("$bin" simulate --family segmented-finger --print-config |
    awk '/^\[material\]/ { p = 1; print; next } /^\[/ { p = 0 } p')
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
    case " ${DESIGNS:-$name} " in *" $name "*) ;; *) continue ;; esac
    cfg="$out/$name.toml"
    if [ "$reading" = family ]; then
        printf '[geometry]\nfamily = "segmented-finger"\n[finger]\nheight_mm = %s\nbellows = %s\nwall_mm = %s\nfoot_mm = %s\n' \
            "$h" "$n" "$tsb" "$tof" >"$cfg"
    else
        # The readings' .geo with the numbers above, the family's material and channels.
        bellow=${BELLOW_MM:-6} pitch=${PITCH_MM:-$(echo "130 / $n" | bc -l)} width=${WIDTH_MM:-20}
        if [ -n "${CAVITY_MM:-}" ]; then
            bellow=$(echo "$CAVITY_MM + 2 * $tsb" | bc -l)
            pitch=$(echo "$bellow + ${GAP_MM:-1.5}" | bc -l)
            if [ -n "${CAVITY_WIDTH_MM:-}" ]; then
                width=$(echo "$CAVITY_WIDTH_MM + 2 * $tsb" | bc -l)
            fi
        fi
        [ "$bellow" = 0 ] && bellow=$(echo "$pitch - ${GAP_MM:-1.5}" | bc -l)
        {
            printf '[geometry]\nfamily = "mesh"\nfile = "%s"\n' "$PWD/examples/geo/segmented_finger.geo"
            printf '[geometry.parameters]\nH = %s\nN = %s\nTSB = %s\nTOF = %s\nNMCP = %s\nB = %s\nSHEET = %s\nSIDE = %s\nCHANNEL = %s\nROOF = %s\nGAP = %s\nPITCH = %s\nSIDEWALL = %s\nW = %s\n' \
                "$h" "$n" "$tsb" "$tof" $(((n + 2) / 3)) "$bellow" "$sheet" "${SIDE:-0}" "${CHANNEL_MM:-0}" "${ROOF_MM:-0}" "${GAP_MM:-1.5}" "$pitch" "${SIDEWALL_MM:-0}" "$width"
            printf '%s\n' "$material"
            printf '[cavities]\nmcp = 1.0\npip_dip = 1.0\n'
            if [ "$sheet" != 0 ]; then
                printf '[[layer]]\nname = "sheet"\nthickness_mm = %s\nyoungs_modulus_mpa = %s\npoisson_ratio = 0.45\n' \
                    "${SHEET_MM:-0.5}" "${SHEET_MPA:-1000}"
            fi
        } >"$cfg"
    fi
    printf '[mesh]\nsize_mm = %s\n[load]\npressures_kpa = "%s"\ngravity = false\n' "$size" "$pressures" >>"$cfg"
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
