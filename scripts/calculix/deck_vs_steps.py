#!/usr/bin/env python3
"""Compare CalculiX's answer on a deck bendscope exported with bendscope's own answer.

Usage: deck_vs_steps.py CCX_DIR FEM_DIR [LABEL]

CCX_DIR holds deck.inp and the deck.dat ccx wrote; FEM_DIR holds bendscope's steps.csv.
Prints one line per ramp pressure: Pratt radius of the markers (x-z plane) and tip
deflection (-z) for both solvers and their ratios. Before that it checks the deck's
C3D10 elements and loaded faces: every mid-node at its edge's midpoint in C3D10 order,
every element of positive volume, and the volume the loaded faces enclose with the
y = 0 symmetry plane (twice it: the whole cavity), so a deck that loads the wrong
faces or orders its nodes differently shows up here before any solver runs.
"""
import csv
import math
import sys

# C3D10 mid-nodes (0-based positions 4..9) on the edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4.
EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
# CalculiX's faces of a tetrahedron: F1 1-2-3, F2 1-4-2, F3 2-4-3, F4 3-4-1.
FACES = {1: (0, 1, 2), 2: (0, 3, 1), 3: (1, 3, 2), 4: (2, 3, 0)}


def blocks(lines, head):
    """The data lines of every keyword block whose line starts with `head`."""
    out = []
    for k, line in enumerate(lines):
        if line.upper().startswith(head):
            rows = []
            for l in lines[k + 1 :]:
                if l.startswith("*"):
                    break
                rows.append(l)
            out.append(rows)
    return out


def ints(rows):
    return [int(t) for r in rows for t in r.split(",") if t.strip()]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def pratt_radius(points):
    """Pratt's algebraic circle fit (Chernov's Newton form) of (x, z) points: the radius."""
    n = len(points)
    mx = sum(p[0] for p in points) / n
    my = sum(p[1] for p in points) / n
    mxx = myy = mxy = mxz = myz = mzz = 0.0
    for x, y in points:
        xi, yi = x - mx, y - my
        zi = xi * xi + yi * yi
        mxx += xi * xi / n
        myy += yi * yi / n
        mxy += xi * yi / n
        mxz += xi * zi / n
        myz += yi * zi / n
        mzz += zi * zi / n
    mz = mxx + myy
    cov = mxx * myy - mxy * mxy
    a2 = 4 * cov - 3 * mz * mz - mzz
    a1 = mzz * mz + 4 * cov * mz - mxz * mxz - myz * myz - mz ** 3
    a0 = mxz * mxz * myy + myz * myz * mxx - mzz * cov - 2 * mxz * myz * mxy + mz * mz * cov
    x, y = 0.0, 1e20
    for _ in range(100):
        y_old, y = y, a0 + x * (a1 + x * (a2 + 4 * x * x))
        if abs(y) > abs(y_old):
            break
        dy = a1 + x * (2 * a2 + 16 * x * x)
        x_old, x = x, x - y / dy
        if x != 0 and abs((x - x_old) / x) < 1e-14:
            break
        if x < 0:
            x = 0.0
    det = x * x - x * mz + cov
    cx = (mxz * (myy - x) - myz * mxy) / det / 2
    cy = (myz * (mxx - x) - mxz * mxy) / det / 2
    return math.sqrt(cx * cx + cy * cy + mz + 2 * x)


def check_deck(lines, nodes):
    """C3D10 order, positive volumes, the loaded faces' enclosed volume (whole cavity)."""
    elements = {}
    for rows in blocks(lines, "*ELEMENT, TYPE=C3D10"):
        vals = ints(rows)
        for k in range(0, len(vals), 11):
            elements[vals[k]] = vals[k + 1 : k + 11]
    worst_mid, min_vol = 0.0, math.inf
    for conn in elements.values():
        x = [nodes[i] for i in conn]
        for m, (a, b) in enumerate(EDGES):
            mid = [(x[a][j] + x[b][j]) / 2 for j in range(3)]
            worst_mid = max(worst_mid, math.dist(mid, x[4 + m]))
        min_vol = min(min_vol, dot(cross(sub(x[1], x[0]), sub(x[2], x[0])), sub(x[3], x[0])) / 6)
    loads = blocks(lines, "*DLOAD")
    volume = 0.0
    for row in loads[0] if loads else []:
        t = [s.strip() for s in row.split(",")]
        conn = elements[int(t[0])]
        face = FACES[int(t[1][1:])]
        p = [nodes[conn[i]] for i in face]
        opposite = nodes[conn[6 - sum(face)]]
        n = cross(sub(p[1], p[0]), sub(p[2], p[0]))  # twice the area
        c = [(p[0][j] + p[1][j] + p[2][j]) / 3 for j in range(3)]
        if dot(n, sub(c, opposite)) < 0:
            n = [-v for v in n]  # the element's outward normal
        # The cavity's outward normal is -n; divergence of (0, y, 0) over the half cavity.
        volume += -c[1] * n[1] / 2
    print(f"deck: {len(elements)} C3D10, mid-nodes off their edge midpoints by at most "
          f"{worst_mid:.1e} mm, smallest element volume {min_vol:.3g} mm3, "
          f"{len(loads[0]) if loads else 0} loaded faces enclosing {2 * volume:.1f} mm3 "
          f"(whole cavity, y = 0 mirrored)")


def main():
    ccx_dir, fem_dir = sys.argv[1], sys.argv[2]
    label = sys.argv[3] if len(sys.argv) > 3 else ""
    lines = open(f"{ccx_dir}/deck.inp").read().splitlines()
    nodes = {}
    for rows in blocks(lines, "*NODE,"):
        for r in rows:
            v = r.split(",")
            nodes[int(v[0])] = [float(t) for t in v[1:4]]
    check_deck(lines, nodes)
    markers = ints(blocks(lines, "*NSET, NSET=MARKERS")[0])
    tip = ints(blocks(lines, "*NSET, NSET=TIP")[0])[0]
    dat = open(f"{ccx_dir}/deck.dat").read().splitlines()
    prints = {"MARKERS": [], "TIP": []}
    for k, l in enumerate(dat):
        for s in prints:
            if l.strip().startswith(f"displacements (vx,vy,vz) for set {s} and time"):
                u = {}
                for r in dat[k + 2 :]:
                    if not r.strip():
                        break
                    v = r.split()
                    u[int(v[0])] = [float(t) for t in v[1:4]]
                prints[s].append(u)
    with open(f"{fem_dir}/steps.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(prints["MARKERS"]) == len(rows), "one CalculiX print per ramp pressure"
    z_tip = nodes[tip][2]
    for row, um, ut in zip(rows, prints["MARKERS"], prints["TIP"]):
        pts = [(nodes[i][0] + um[i][0], nodes[i][2] + um[i][2]) for i in markers]
        r_ccx, r_bs = pratt_radius(pts), float(row["radius_mm"])
        d_ccx, d_bs = -ut[tip][2], z_tip - float(row["tip_z_mm"])
        print(f"{label}{float(row['pressure_kpa']):g} kPa | radius bendscope {r_bs:.2f} "
              f"CalculiX {r_ccx:.2f} mm ({100 * (r_ccx / r_bs - 1):+.2f}%) | tip deflection "
              f"bendscope {d_bs:.3f} CalculiX {d_ccx:.3f} mm ({100 * (d_ccx / d_bs - 1):+.2f}%)")


if __name__ == "__main__":
    main()
