#!/usr/bin/env python3
"""Writes a CalculiX deck: a soft cube with a box cavity in 10-node tetrahedra, rotated.

The rotated-deck check of ccx_peer's follower-pressure load stiffness (scripts/ccx-peer.sh):
the same deck in every orientation must reach the same pressure and the same displacements
(rotated back). The cube (side 12 mm, 2 mm cells, each split into 6 tetrahedra along its
main diagonal, so neighbouring cells share their face diagonals) has a 4 x 4 x 4 mm cavity
above the middle of its clamped face z = 0; the cavity faces carry the pressure (`*DLOAD`
P1-P4, a follower load), one `*STEP, NLGEOM` with automatic increments ramps it to
--pressure-kpa. Material: Yeoh with C20 = C30 = 0 (neo-Hooke), C10 = 0.01 MPa, D1 = 1/MPa
(bulk modulus 100 mu0), as bendscope exports silicone. Every node is rotated by --angle
about --axis through the cube's centre, so the clamp and the loaded faces rotate with it.
`TRACK` is the node at the centre of the top face (z = 12 mm before the rotation); its
displacement is printed at every increment (`*NODE PRINT`, model.dat), so the last block
is the last converged increment. --tight adds `*CONTROLS` with tight tolerances and two
steps holding the pressure (time 1 to 3), for comparing two solvers' answers closely.

Usage: cavity_cube.py [--angle DEG] [--axis X,Y,Z] [--pressure-kpa P] [--tight] OUT.inp
Python 3 standard library only.
"""

import argparse
import math
import os
import sys

SIDE_CELLS = 6
CELL_MM = 2.0
# The cavity's cells: x, y in [2, 4) and z in [2, 4) cells (4 mm walls below and around,
# 4 mm roof).
CAVITY = (range(2, 4), range(2, 4), range(2, 4))
C10_MPA = 0.01
D1_PER_MPA = 1.0

# Kuhn's split of the unit cube (corners as bits x + 2y + 4z) into 6 tetrahedra sharing
# the diagonal 0-7: translation-invariant, so neighbouring cells' faces match.
KUHN = [
    (0, 1, 3, 7),
    (0, 3, 2, 7),
    (0, 2, 6, 7),
    (0, 6, 4, 7),
    (0, 4, 5, 7),
    (0, 5, 1, 7),
]
# CalculiX C3D10 faces by their corners (local 1-based): P1 = 1-2-3, P2 = 1-2-4,
# P3 = 2-3-4, P4 = 1-3-4; midside nodes 5-10 on the edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4.
FACES = {1: (0, 1, 2), 2: (0, 1, 3), 3: (1, 2, 3), 4: (0, 2, 3)}
EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]


def rotation(axis, angle_deg):
    """The rotation matrix (rows) by angle_deg about the unit vector along axis."""
    n = math.sqrt(sum(a * a for a in axis))
    x, y, z = (a / n for a in axis)
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    t = 1.0 - c
    return [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]


def volume6(a, b, c, d):
    """Six times the signed volume of the tetrahedron a b c d."""
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    w = [d[i] - a[i] for i in range(3)]
    return (
        u[0] * (v[1] * w[2] - v[2] * w[1])
        - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
    )


def mesh():
    """Nodes (grid coordinates in half cells, unrotated mm), C3D10 connectivity (0-based)
    and the loaded faces (element, face number)."""
    n = SIDE_CELLS
    nodes = []
    index = {}

    def node(key):
        if key not in index:
            index[key] = len(nodes)
            nodes.append(tuple(k * CELL_MM / 2.0 for k in key))
        return index[key]

    def in_cavity(i, j, k):
        return i in CAVITY[0] and j in CAVITY[1] and k in CAVITY[2]

    elements = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                if in_cavity(i, j, k):
                    continue
                corner = [
                    (2 * (i + (b & 1)), 2 * (j + (b >> 1 & 1)), 2 * (k + (b >> 2 & 1)))
                    for b in range(8)
                ]
                for tet in KUHN:
                    c = [corner[b] for b in tet]
                    if volume6(*c) < 0:
                        c[1], c[2] = c[2], c[1]
                    mids = [
                        tuple((c[a][d] + c[b][d]) // 2 for d in range(3)) for a, b in EDGES
                    ]
                    elements.append([node(p) for p in c + mids])
    # A face is loaded when its three corners lie on the cavity's boundary, in one of its
    # six planes (grid units: half cells).
    lo = [2 * r.start for r in CAVITY]
    hi = [2 * r.stop for r in CAVITY]
    inv = {v: key for key, v in index.items()}

    def on_cavity(face_keys):
        for d in range(3):
            for plane in (lo[d], hi[d]):
                if all(p[d] == plane for p in face_keys) and all(
                    lo[e] <= p[e] <= hi[e] for p in face_keys for e in range(3) if e != d
                ):
                    return True
        return False

    loads = []
    for e, conn in enumerate(elements):
        for number, corners in FACES.items():
            if on_cavity([inv[conn[c]] for c in corners]):
                loads.append((e, number))
    return nodes, elements, loads


def deck(angle_deg, axis, pressure_kpa, tight):
    """The deck's text."""
    nodes, elements, loads = mesh()
    r = rotation(axis, angle_deg)
    centre = SIDE_CELLS * CELL_MM / 2.0
    out = ["** cavity_cube.py: soft cube, box cavity, C3D10, rotated %g deg about %s"
           % (angle_deg, ",".join("%g" % a for a in axis)), "*NODE"]
    for i, p in enumerate(nodes):
        q = [p[d] - centre for d in range(3)]
        x = [sum(r[a][b] * q[b] for b in range(3)) + centre for a in range(3)]
        # 13 significant digits: CalculiX reads at most 20 characters of a number.
        out.append("%d, %.12e, %.12e, %.12e" % (i + 1, x[0], x[1], x[2]))
    out.append("*ELEMENT, TYPE=C3D10, ELSET=EALL")
    for e, conn in enumerate(elements):
        out.append("%d, %s" % (e + 1, ", ".join(str(c + 1) for c in conn)))
    top = SIDE_CELLS * CELL_MM
    clamped = [i + 1 for i, p in enumerate(nodes) if p[2] == 0.0]
    track = [i + 1 for i, p in enumerate(nodes) if p == (centre, centre, top)]
    for name, ids in (("CLAMPED", clamped), ("TRACK", track)):
        out.append("*NSET, NSET=%s" % name)
        out.extend(", ".join(str(v) for v in ids[k:k + 12]) for k in range(0, len(ids), 12))
    out += [
        "*MATERIAL, NAME=SOFT",
        "*HYPERELASTIC, YEOH",
        "%.9e, 0., 0., %.9e, 0., 0." % (C10_MPA, D1_PER_MPA),
        "*SOLID SECTION, ELSET=EALL, MATERIAL=SOFT",
        "*BOUNDARY",
        "CLAMPED, 1, 3",
        "*STEP, NLGEOM, INC=1000",
        "*STATIC",
        "0.1, 1., 1e-5, 0.25",
    ]
    # Residual and correction tolerances far below the defaults (0.005, 0.01 of a
    # reference force and displacement; the force set to the deck's scale, 1e-5 N), more
    # iterations allowed before a cutback.
    controls = ["*CONTROLS, PARAMETERS=FIELD", "1e-9, 1e-9, 0, 1e-5, 1e-9, 1e-12, 1e-9, 1e-30",
                "*CONTROLS, PARAMETERS=TIME INCREMENTATION", "40, 80, 9, 200, 10, 4, 0, 5"]
    if tight:
        out += controls
    out.append("*DLOAD")
    out.extend("%d, P%d, %.9e" % (e + 1, f, pressure_kpa * 1e-3) for e, f in loads)
    out += ["*NODE PRINT, NSET=TRACK", "U", "*END STEP"]
    if tight:
        # CalculiX checks convergence against the pressure of the configuration before the
        # last correction (a follower load lags an iteration), so a step ends off
        # equilibrium by about its last correction: two steps holding the pressure take the
        # solution to equilibrium whatever the tangent.
        for _ in range(2):
            out += ["*STEP, NLGEOM, INC=100", "*STATIC", "1., 1.", *controls,
                    "*NODE PRINT, NSET=TRACK", "U", "*END STEP"]
    out.append("")
    return "\n".join(out)


def refuse(message):
    """Bad input: one line on stderr, exit 2."""
    print("cavity_cube.py: " + message, file=sys.stderr)
    sys.exit(2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="the deck to write, e.g. model.inp")
    ap.add_argument("--angle", type=float, default=0.0, help="rotation in degrees (0)")
    ap.add_argument("--axis", default="0,0,1", help="rotation axis x,y,z (0,0,1)")
    ap.add_argument("--pressure-kpa", type=float, default=40.0, help="cavity pressure (40)")
    ap.add_argument("--tight", action="store_true", help="tight tolerances, two steps holding the pressure")
    a = ap.parse_args()
    try:
        axis = [float(v) for v in a.axis.split(",")]
    except ValueError:
        axis = []
    if len(axis) != 3 or not all(math.isfinite(v) for v in axis) or not any(axis):
        refuse("--axis %r is not three finite numbers, not all zero "
                 "(e.g. --axis 1,2,3)" % a.axis)
    if not math.isfinite(a.angle):
        refuse("--angle %r is not a finite number of degrees (e.g. 30)"
                 % a.angle)
    if not (math.isfinite(a.pressure_kpa) and 0.0 < a.pressure_kpa < 1e4):
        refuse("--pressure-kpa %r is outside (0, 10000) kPa (e.g. 40)"
                 % a.pressure_kpa)
    text = deck(a.angle, axis, a.pressure_kpa, a.tight)
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
