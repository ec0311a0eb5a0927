#!/usr/bin/env python3
"""The rotated-deck check of ccx_peer's follower-pressure load stiffness.

The deck of cavity_cube.py (a soft cube with a pressurised box cavity, C3D10) is solved by
ccx_peer as it is and rotated: by 30 deg about z (four cavity faces tilted about one axis)
and by 30 and 45 deg about (1, 2, 3) (every face tilted). A rotated deck is the same
discrete problem, so every orientation must reach the full pressure and give the same
displacement at the tracked node (the top face's centre) once rotated back, within
ROTATED_TOL of its size. Then stock ccx and ccx_peer solve the 45 deg deck at a small
pressure, where stock ccx converges: the patch changes the tangent only, so the two answers
must agree within STOCK_TOL (every deck with tight tolerances and two steps holding the
pressure, cavity_cube.py --tight).
The decks run two at a time, one thread each; about half a minute on 2 cores.

Usage: rotated_cube_check.py [CCX_PEER] [CCX]
  (defaults target/ccx-peer/ccx_peer, built by scripts/ccx-peer.sh, and ccx on PATH).
Exit 0 when every check holds, 1 with one line per failed check, 2 when a solver is missing.
Python 3 standard library only.
"""

import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import cavity_cube  # noqa: E402

# The full ramp of the rotated decks, kPa: below the cube's limit point, well past where
# the load stiffness with the tilted-face fault (doubled there) stops.
PRESSURE_KPA = 18.0
# The small pressure where stock ccx converges in every orientation, kPa.
SMALL_KPA = 2.0
# Largest difference between orientations of the tracked node's displacement (rotated
# back), as a share of its size: the decks are converged tightly; .dat prints 7 digits.
ROTATED_TOL = 1e-5
# Largest difference between stock ccx and ccx_peer, as a share of the displacement.
STOCK_TOL = 1e-6
# A run taking longer than this (seconds) is stopped where it got to.
TIMEOUT_S = 120
ORIENTATIONS = [(0.0, (0.0, 0.0, 1.0)), (30.0, (0.0, 0.0, 1.0)),
                (30.0, (1.0, 2.0, 3.0)), (45.0, (1.0, 2.0, 3.0))]
BLOCK = re.compile(r"displacements \(vx,vy,vz\) for set TRACK and time\s+(\S+)\s+\d+\s+(\S+)\s+(\S+)\s+(\S+)")


def solve(ccx, angle, axis, pressure_kpa, work):
    """Runs ccx on the cube's deck; returns (pressure reached in kPa, the tracked node's
    displacement rotated back to the unrotated deck, mm)."""
    d = tempfile.mkdtemp(dir=work)
    path = os.path.join(d, "model.inp")
    with open(path, "w") as f:
        f.write(cavity_cube.deck(angle, list(axis), pressure_kpa, True))
    env = dict(os.environ, OMP_NUM_THREADS="1")
    try:
        subprocess.run([ccx, "-i", "model"], cwd=d, env=env, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, timeout=TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        pass  # what it converged so far is in model.dat: it counts as stopped there
    try:
        with open(os.path.join(d, "model.dat")) as f:
            blocks = BLOCK.findall(f.read())
    except OSError:
        blocks = []
    if not blocks:
        return 0.0, [math.nan] * 3
    # The ramp runs over time 0 to 1, the two holding steps (cavity_cube.py --tight) to 3.
    t, *u = (float(v) for v in blocks[-1])
    t = min(t, 1.0)
    r = cavity_cube.rotation(axis, angle)
    back = [sum(r[b][a] * u[b] for b in range(3)) for a in range(3)]
    return t * pressure_kpa, back


def main():
    peer = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/ccx-peer/ccx_peer")
    stock = sys.argv[2] if len(sys.argv) > 2 else (shutil.which("ccx") or "ccx")
    for name, exe in (("ccx_peer", peer), ("ccx", stock)):
        if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
            print("rotated_cube_check: %s %s is missing: run scripts/ccx-peer.sh and "
                  "scripts/setup.sh (scripts/test.sh does)" % (name, exe), file=sys.stderr)
            return 2
    failed = []
    with tempfile.TemporaryDirectory() as work, ThreadPoolExecutor(2) as pool:
        runs = [pool.submit(solve, peer, a, ax, PRESSURE_KPA, work) for a, ax in ORIENTATIONS]
        angle, axis = ORIENTATIONS[-1]
        small = [pool.submit(solve, exe, angle, axis, SMALL_KPA, work) for exe in (stock, peer)]
        results = [r.result() for r in runs]
        (p_stock, u_stock), (p_peer, u_peer) = (r.result() for r in small)
    _, u0 = results[0]
    size = math.sqrt(sum(v * v for v in u0))
    for (angle, axis), (p, u) in zip(ORIENTATIONS, results):
        gap = math.sqrt(sum((a - b) ** 2 for a, b in zip(u, u0))) / size
        print("ccx_peer %4.0f deg about (%g, %g, %g): %.3f of %.3f kPa, tracked node "
              "(%.6f, %.6f, %.6f) mm, %.2e from 0 deg"
              % (angle, *axis, p, PRESSURE_KPA, *u, gap))
        if abs(p - PRESSURE_KPA) > 1e-6 * PRESSURE_KPA:
            failed.append("ccx_peer %g deg about (%g, %g, %g) stopped at %.3f kPa of %g"
                          % (angle, *axis, p, PRESSURE_KPA))
        elif not gap <= ROTATED_TOL:
            failed.append("ccx_peer %g deg about (%g, %g, %g): tracked node %.2e from 0 deg "
                          "(more than %g)" % (angle, *axis, gap, ROTATED_TOL))
    gap = math.sqrt(sum((a - b) ** 2 for a, b in zip(u_stock, u_peer))) / math.sqrt(
        sum(v * v for v in u_stock))
    print("%g kPa, %g deg about (%g, %g, %g): stock ccx %.3f kPa (%.7e, %.7e, %.7e), "
          "ccx_peer %.3f kPa, %.2e apart"
          % (SMALL_KPA, angle, *axis, p_stock, *u_stock, p_peer, gap))
    if not (p_stock == p_peer == SMALL_KPA and gap <= STOCK_TOL):
        failed.append("stock ccx and ccx_peer at %g kPa: %.3f / %.3f kPa, %.2e apart "
                      "(more than %g)" % (SMALL_KPA, p_stock, p_peer, gap, STOCK_TOL))
    for f in failed:
        print("rotated_cube_check: FAILED: " + f, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
