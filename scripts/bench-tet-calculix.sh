#!/usr/bin/env bash
# Benchmark of the quadratic tetrahedra (Taylor-Hood P2/P1, the default tet element) against
# stock CalculiX (Debian's calculix-ccx, C3D10: displacement-only, it has no hybrid
# tetrahedron) on the deck bendscope exports, and of the tetrahedra's speed (issue 39):
# - comparisons: the reference actuator's .geo (examples/geo/pneunets_reference.geo, the
#   mesh study's 2 mm roof) meshed by gmsh, no gravity, 5 and 10 kPa, per CASES entry
#   SIZE:K (gmsh size in mm, bulk modulus in multiples of mu0 = 0.21488 MPa): both
#   solvers' marker radius (Pratt) and tip deflection, the deck checks of
#   scripts/calculix/deck_vs_steps.py, bendscope's and ccx's wall and CPU seconds;
# - the default ramp (10:115:5 kPa) of the gmsh mesh at each of RAMP_SIZES mm (default
#   "3 2.5 2") in the mesh study's configuration (no gravity, 100 mu0) with the default
#   threads: wall and CPU seconds and the radius against the converged hexahedra (issue
#   11's table, the figures tests/tetrahedra.rs asserts), then ccx on the first size's
#   exported deck (CCX_TIMEOUT s, default 3600: stock ccx takes minutes per step there);
#   BASE_BIN=path/to/baseline/bendscope also runs each ramp with that binary, for the
#   ratio of their wall times (run in the same session, the machine otherwise idle).
# BIN=path/to/bendscope uses that binary instead of building one; CASES="3:20 2:100"
# picks the comparisons ("" for none); RAMP=0 skips the ramp, CCX_RAMP=0 its ccx run;
# CCX_THREADS (default 2) is ccx's OMP_NUM_THREADS; TABLE_ONLY=1 prints the table of an
# earlier run in OUT. The machine may be shared: wall times then stretch, CPU times less.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${BIN:-}" ]; then
  cargo build --release --locked --bin bendscope
  bin=$PWD/target/release/bendscope
else
  bin=$(realpath "$BIN")
fi
out=$(realpath -m "${OUT:-target/bench/tet-calculix}")
cases=${CASES-"3:10 3:20 3:100 2:10 2:100 1.5:10"}
threads=${CCX_THREADS:-2}
mu0=0.21488
compare=$PWD/scripts/calculix/deck_vs_steps.py
mkdir -p "$out"
sed 's/roof = {1, /roof = {2, /' examples/geo/pneunets_reference.geo > "$out/reference.geo"
grep -q 'roof = {2, ' "$out/reference.geo" || { echo "the .geo's roof constant moved" >&2; exit 1; }

# setup DIR SIZE: a run directory with the .geo and a config meshing it at SIZE mm.
setup() {
  rm -rf "$1" && mkdir -p "$1"
  cp "$out/reference.geo" "$1/"
  printf '[geometry]\nfamily = "mesh"\nfile = "reference.geo"\n[mesh]\nsize_mm = %s\n' "$2" > "$1/geo.toml"
}
# ccx_in DIR: stock ccx on DIR/deck.inp, timed into DIR/time.txt (wall, user, system s).
ccx_in() {
  (cd "$1" && /usr/bin/time -f "%e %U %S" -o time.txt env OMP_NUM_THREADS="$threads" \
    timeout "${CCX_TIMEOUT:-3600}" ccx -i deck > ccx.log 2>&1) || echo "ccx in $1 stopped: see ccx.log" >&2
}

if [ -z "${TABLE_ONLY:-}" ]; then
  for c in $cases; do
    size=${c%%:*}; k=${c##*:}
    d="$out/cmp-$size-$k"
    setup "$d" "$size"
    (cd "$d" && /usr/bin/time -f "%e %U %S" -o bendscope.time "$bin" simulate --config geo.toml \
      --pressures 5,10 --no-gravity --bulk-modulus "$(python3 -c "print($k * $mu0)")" --no-vtu \
      -o fem --export-inp ccx/deck.inp > bendscope.log 2>&1)
    ccx_in "$d/ccx"
    python3 "$compare" "$d/ccx" "$d/fem" > "$d/compare.txt" || echo "no comparison in $d" >&2
  done
  if [ "${RAMP:-1}" != 0 ]; then
    first=1
    for size in ${RAMP_SIZES:-3 2.5 2}; do
      d="$out/ramp-$size"
      setup "$d" "$size"
      (cd "$d" && /usr/bin/time -f "%e %U %S" -o bendscope.time "$bin" simulate --config geo.toml \
        --no-gravity --bulk-modulus 21.488 --no-vtu -o fem --export-inp ccx/deck.inp > bendscope.log 2>&1)
      if [ -n "${BASE_BIN:-}" ]; then
        (cd "$d" && /usr/bin/time -f "%e %U %S" -o base.time "$(realpath "$BASE_BIN")" simulate \
          --config geo.toml --no-gravity --bulk-modulus 21.488 --no-vtu -o base > base.log 2>&1)
      fi
      if [ "$first" = 1 ] && [ "${CCX_RAMP:-1}" != 0 ]; then ccx_in "$d/ccx"; fi
      first=0
    done
  fi
fi

python3 - "$out" <<'PY'
import glob, os, re, sys
out = sys.argv[1]
def times(path):
    try:
        wall, user, sys_ = open(path).read().split()[-3:]
        return float(wall), float(user) + float(sys_)
    except (OSError, ValueError):
        return float("nan"), float("nan")
print("CalculiX C3D10 (stock ccx) against bendscope's Taylor-Hood on the same deck, gmsh mesh of the reference .geo, no gravity")
print("| mesh | bulk modulus | kPa | radius bendscope / CalculiX, mm | tip deflection bendscope / CalculiX, mm | bendscope wall / CPU s | ccx wall / CPU s |")
print("|---|---|---|---|---|---|---|")
def key(p):
    size, k = os.path.basename(p).split("-")[1:]
    return (-float(size), float(k))
for d in sorted(glob.glob(f"{out}/cmp-*"), key=key):
    size, k = os.path.basename(d).split("-")[1:]
    bw, bc = times(f"{d}/bendscope.time")
    cw, cc = times(f"{d}/ccx/time.txt")
    try:
        lines = [l for l in open(f"{d}/compare.txt") if "kPa" in l]
    except OSError:
        lines = []
    if not lines:
        print(f"| {size} mm | {k} mu0 | | failed: see {d} | | {bw:.1f} / {bc:.1f} | {cw:.1f} / {cc:.1f} |")
    for l in lines:
        n = [float(x) for x in re.findall(r"[-+]?\d+\.\d+|\d+", l.split("|", 1)[1])]
        p = l.split()[0]
        print(f"| {size} mm | {k} mu0 | {p} | {n[0]:.2f} / {n[1]:.2f} ({n[2]:+.2f}%) | {n[3]:.3f} / {n[4]:.3f} ({n[5]:+.2f}%) | {bw:.1f} / {bc:.1f} | {cw:.1f} / {cc:.1f} |")
ref = {10: 342.9, 40: 92.62, 80: 53.23, 115: 42.52}
ramps = sorted(glob.glob(f"{out}/ramp-*"), key=lambda d: -float(d.rsplit("-", 1)[1]))
if ramps:
    print()
    print("Default ramp 10:115:5 kPa, 100 mu0, no gravity, the default threads; radius against the converged hexahedra")
    print("| gmsh size | nodes | steps | Newton iterations | wall / CPU s | baseline wall s (ratio) | 10 kPa | 40 kPa | 80 kPa | 115 kPa | max deviation |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
for d in ramps:
    size = d.rsplit("-", 1)[1]
    if not os.path.exists(f"{d}/fem/steps.csv"):
        print(f"| {size} mm | failed: see {d}/bendscope.log | | | | | | | | | |")
        continue
    rows = [l.split(",") for l in open(f"{d}/fem/steps.csv").read().split()[1:]]
    r = {round(float(row[0])): float(row[1]) for row in rows}
    bw, bc = times(f"{d}/bendscope.time")
    base_wall, _ = times(f"{d}/base.time")
    base = f"{base_wall:.1f} ({base_wall / bw:.2f}x)" if base_wall == base_wall else ""
    log = open(f"{d}/bendscope.log").read()
    newton = re.search(r"(\d+) Newton iterations", log)
    nodes = re.search(r"\((\d+) nodes", log)
    cells = " | ".join(f"{r[p]:.2f} ({100 * (r[p] / ref[p] - 1):+.2f}%)" if p in r else "" for p in ref)
    dev = max(abs(r[p] / ref[p] - 1) for p in ref if p in r)
    print(f"| {size} mm | {nodes.group(1) if nodes else '?'} | {len(rows)} | "
          f"{newton.group(1) if newton else '?'} | {bw:.1f} / {bc:.1f} | {base} | {cells} | {100 * dev:.2f}% |")
for d in ramps:
    if not os.path.exists(f"{d}/ccx/time.txt"):
        continue
    cw, cc = times(f"{d}/ccx/time.txt")
    try:
        sta = [l.split() for l in open(f"{d}/ccx/deck.sta") if re.match(r"\s+\d+\s+\d+", l)]
        finished = "Total CalculiX Time" in open(f"{d}/ccx/ccx.log").read()
    except OSError:
        sta, finished = [], False
    if cw == cw:
        last = sta[-1][0] if sta else "0"
        state = "finished" if finished else f"stopped in step {last}"
        print(f"ccx on the {d.rsplit('-', 1)[1]} mm ramp's deck (stock, C3D10, OMP_NUM_THREADS as run): "
              f"wall {cw:.1f} s, CPU {cc:.1f} s, {state} of 22 steps")
PY
