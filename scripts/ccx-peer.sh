#!/usr/bin/env bash
# Builds ccx_peer: CalculiX ccx 2.20 from Debian's own source package (calculix-ccx) with a
# patch to e_c3d.f (scripts/calculix/ccx_pressure_stiffness.patch) that adds the
# follower-pressure load stiffness to the Newton tangent of NLGEOM static steps, and prints
# its path. Reused once built from the same patch (about 2 minutes on 2 cores), also from
# ~/.cache/bendscope/ccx-peer where a build of the same patch is kept for other checkouts.
#
# The patch enables the load stiffness stock ccx computes for dynamic steps, and computes
# the gradients along the loaded face it needs from the face's dual basis: the shape
# routines' global derivatives (iflag=3) are not an inverse of the face's tangents on a
# face that is not parallel to a coordinate plane, which doubled the load stiffness there
# (scripts/calculix/rotated_cube_check.py checks every orientation).
#
# Why: stock ccx computes *DLOAD pressure on the deformed faces (a follower load) but adds
# the matching load stiffness to the tangent only when a mass matrix is assembled, so its
# static Newton converges linearly and gives up on soft actuators at larger pressures (the
# glove's deck at 2 kPa). The patch changes the tangent only, not the residual: where stock
# ccx converges, ccx_peer's answer is the same. The tests check exported decks with it.
#
# Usage: scripts/ccx-peer.sh [OUT_DIR]   (default target/ccx-peer; installs the build
# packages and adds a deb-src source for Debian when missing; scripts/test.sh runs it)
set -euo pipefail
cd "$(dirname "$0")/.."
HERE="$PWD/scripts/calculix"
OUT="$(realpath -m "${1:-target/ccx-peer}")"
# The binary is reused only when built from this patch and Makefile: their sha256 is kept
# beside it (ccx_peer.sha256), so a changed patch rebuilds it.
STAMP="$(cat "$HERE/ccx_pressure_stiffness.patch" "$HERE/Makefile_peer" | sha256sum | cut -d' ' -f1)"
if [ -x "$OUT/ccx_peer" ] && [ "$(cat "$OUT/ccx_peer.sha256" 2>/dev/null)" = "$STAMP" ]; then
  echo "$OUT/ccx_peer"
  exit 0
fi
# place BINARY: BINARY as $OUT/ccx_peer beside its stamp, each written whole (.tmp, mv).
place() {
  mkdir -p "$OUT" && cp "$1" "$OUT/ccx_peer.tmp" && mv "$OUT/ccx_peer.tmp" "$OUT/ccx_peer" &&
    echo "$STAMP" >"$OUT/ccx_peer.sha256.tmp" && mv "$OUT/ccx_peer.sha256.tmp" "$OUT/ccx_peer.sha256"
}
# A build of this patch kept in the user's cache by an earlier checkout is copied.
CACHE="${XDG_CACHE_HOME:-$HOME/.cache}/bendscope/ccx-peer/$STAMP"
if [ -x "$CACHE/ccx_peer" ] && place "$CACHE/ccx_peer"; then
  echo "$OUT/ccx_peer"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
scripts/apt-need.sh ccx-peer gfortran libspooles-dev libarpack2-dev liblapack-dev libblas-dev \
  patch dpkg-dev >/dev/null
if ! grep -rqs "^Types:.*deb-src\|^deb-src" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    sed 's/^Types: deb$/Types: deb-src/' /etc/apt/sources.list.d/debian.sources |
      $SUDO tee /etc/apt/sources.list.d/debian-src.sources >/dev/null
  else
    sed -n 's/^deb /deb-src /p' /etc/apt/sources.list | $SUDO tee /etc/apt/sources.list.d/debian-src.list >/dev/null
  fi
  $SUDO apt-get update -q >/dev/null
fi
WORK="$(mktemp -d /tmp/ccx-peer.XXXX)"
trap 'rm -rf "$WORK"' EXIT
(cd "$WORK" && apt-get source -q calculix-ccx >/dev/null 2>&1) || {
  echo "ccx-peer: apt-get source calculix-ccx failed (no deb-src source?)" >&2
  exit 1
}
SRC="$(dirname "$(find "$WORK" -name e_c3d.f | head -1)")"
# The release tarball names its main ccx_2.20.c.
[ -f "$SRC/CalculiX.c" ] || cp "$SRC"/ccx_2.*.c "$SRC/CalculiX.c"
cd "$SRC"
patch -p1 -s <"$HERE/ccx_pressure_stiffness.patch"
cp "$HERE/Makefile_peer" .
make -f Makefile_peer -j"$(nproc)" ccx_peer >build.log 2>&1 || {
  tail -30 build.log >&2
  exit 1
}
place ccx_peer || {
  echo "ccx-peer: cannot write $OUT/ccx_peer" >&2
  exit 1
}
# Kept for other checkouts (best effort: a cache that cannot be written is no error).
(mkdir -p "$CACHE" && cp ccx_peer "$CACHE/ccx_peer.tmp" && mv "$CACHE/ccx_peer.tmp" "$CACHE/ccx_peer") 2>/dev/null || true
echo "$OUT/ccx_peer"
