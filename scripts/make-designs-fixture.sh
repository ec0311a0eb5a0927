#!/usr/bin/env bash
# Runs the 16 real FEM simulations of a 2-factor plan (4 x 4 factorial over the bottom
# thickness geometry.f and the chamber height geometry.n, 3 mm mesh, ramp 10:100:10 kPa)
# and writes fixtures/designs/two-factor.csv in the designs.csv format of `bendscope sweep`:
# id, status, seconds, geometry.f, geometry.n, then for P in 50 and 100 kPa radius_mm@P,
# curvature_per_m@P, bending_angle_deg@P, max_principal_stress_mpa@P, safety_factor@P,
# bottom_elongation_pct@P, cavity_volume_mm3@P, and height_mm. The numbers are copied from
# each run's steps.csv and summary.json (what `bendscope simulate` writes).
#
# Usage: scripts/make-designs-fixture.sh [OUT.csv]   (BENDSCOPE=path/to/bendscope, JOBS=2)
# Use an optimized binary (`cargo build --profile test --bin bendscope`, opt-level 2): the
# dev profile's (opt-level 0) is about 70x slower on the FEM. 13 CPU-minutes for the 16
# points with an optimized binary (18 min wall on a loaded 2-core machine, JOBS=2).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-fixtures/designs/two-factor.csv}
BENDSCOPE=${BENDSCOPE:-${CARGO_TARGET_DIR:-target}/debug/bendscope}
JOBS=${JOBS:-2}
F_LEVELS="3 4.5 6 7.5"
N_LEVELS="8 10 12 14"
KEPT="50 100"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

id=0
for f in $F_LEVELS; do
  for n in $N_LEVELS; do
    id=$((id + 1))
    mkdir -p "$WORK/$id"
    cat > "$WORK/$id/actuator.toml" <<TOML
[geometry]
f = $f
n = $n
[mesh]
size_mm = 3.0
[load]
pressures_kpa = "10:100:10"
TOML
    echo "$id $f $n"
  done
done > "$WORK/points.txt"

run_point() {
  local id=$1 dir=$2 exe=$3
  if "$exe" simulate --config "$dir/$id/actuator.toml" --no-vtu -o "$dir/$id/run" \
      > "$dir/$id/log" 2>&1; then
    echo ok > "$dir/$id/status"
  else
    echo "failed: exit $? ($(tail -n 1 "$dir/$id/log" | tr ',' ';'))" > "$dir/$id/status"
  fi
  echo "point $id done: $(cat "$dir/$id/status")" >&2
}
export -f run_point
cut -d' ' -f1 "$WORK/points.txt" | xargs -P "$JOBS" -I{} bash -c 'run_point "$@"' _ {} "$WORK" "$BENDSCOPE"

# One row per point. Columns of steps.csv by name; the pressure rows by value.
{
  printf 'id,status,seconds,geometry.f,geometry.n'
  for p in $KEPT; do
    for c in radius_mm curvature_per_m bending_angle_deg max_principal_stress_mpa safety_factor bottom_elongation_pct cavity_volume_mm3; do
      printf ',%s@%s' "$c" "$p"
    done
  done
  printf ',height_mm\n'
  while read -r id f n; do
    run="$WORK/$id/run"
    status=$(cat "$WORK/$id/status")
    seconds=$(grep -o '"seconds": *[0-9.eE+-]*' "$run/summary.json" 2>/dev/null | grep -o '[0-9.eE+-]*$' || true)
    height=$(awk -v f="$f" -v n="$n" '/^\[/{s=$0} s=="[geometry]" && $1=="m"{m=$3} s=="[geometry]" && $1=="top_wall"{t=$3} END{printf "%.4f", f+m+n+t}' "$run/config.toml")
    printf '%s,%s,%s,%s,%s' "$id" "$status" "$seconds" "$f" "$n"
    for p in $KEPT; do
      awk -F, -v p="$p" '
        NR==1 { for (i=1;i<=NF;i++) col[$i]=i; next }
        $col["pressure_kpa"]+0==p+0 { hit=1; split("radius_mm curvature_per_m bending_angle_deg max_principal_stress_mpa safety_factor bottom_elongation_pct cavity_volume_mm3", names, " ");
          for (k=1;k<=7;k++) printf ",%s", $col[names[k]] }
        END { if (!hit) printf ",,,,,,," }' "$run/steps.csv" 2>/dev/null || printf ',,,,,,,'
    done
    printf ',%s\n' "$height"
  done < "$WORK/points.txt"
} > "$OUT.tmp"
mv "$OUT.tmp" "$OUT"
echo "wrote $OUT" >&2
