#!/usr/bin/env python3
"""Splits the radius error of a measured rendered session into its causes.

Usage: decompose.py SESSION OUT [CALIBRATION.yaml]
From OUT/markers.csv (bendscope's dot centroids in the raw frame, averaged per marker
over the frames) and SESSION/truth-pbr.json: each dot's centroid error against its true
centre projected through the true lens (px), and the radius of the centroids taken back
through a lens (the true one, or CALIBRATION.yaml) onto the true marker plane, beside
the radius of the same mean centroids in bendscope's millimetres (markers.csv: its
calibration and scale board). With the
true lens, the rest of bendscope's error is the calibration's and the scale's; this one
is the centroids' alone.
"""
import csv
import json
import math
import re
import sys

import numpy as np
import cv2


def read_yaml_lens(path):
    t = open(path).read()

    def mat(name):
        m = re.search(name + r":.*?data:\s*\[([^\]]*)\]", t, re.S)
        return np.array([float(x) for x in m.group(1).replace("\n", " ").split(",")])
    return mat("camera_matrix").reshape(3, 3), mat("distortion_coefficients")


def circle(P):
    x, y = P[:, 0], P[:, 1]
    A = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, c = np.linalg.lstsq(A, x * x + y * y, rcond=None)[0]
    return math.sqrt(c + cx * cx + cy * cy)


def main():
    session, out = sys.argv[1], sys.argv[2]
    T = json.load(open(f"{session}/truth-pbr.json"))
    cam, scene, act = T["camera"], T["scene"], T["actuator"]
    if len(sys.argv) > 3:
        K, D = read_yaml_lens(sys.argv[3])
    else:
        K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
        D = np.array(cam["k"], float)
    px, mm = {}, {}
    for r in csv.DictReader(open(f"{out}/markers.csv")):
        px.setdefault(r["file"], {}).setdefault(int(r["marker"]), []).append((float(r["x_px"]), float(r["y_px"])))
        mm.setdefault(r["file"], {}).setdefault(int(r["marker"]), []).append((float(r["x_mm"]), float(r["y_mm"])))
    print(f"{'kPa':>5} {'truth R':>9} {'R (centroids, lens)':>20} {'dk 1/m':>8} "
          f"{'mean dx px':>10} {'mean dy px':>10} {'max |d| px':>10} {'radial d px':>11} {'R (bendscope mm)':>16}  "
          "each dot's error normal to the arc, outward, um")
    for v in T["videos"]:
        if v["file"] not in px:
            continue
        m = px[v["file"]]
        uv = np.array([np.mean(m[k], axis=0) for k in sorted(m)])
        tp = np.array(v["dots_px"])
        if len(uv) != len(tp):
            continue
        d = uv - tp
        # Radial component of the error (outward from the principal point).
        rad = tp - np.array([cam["cx"], cam["cy"]])
        rad /= np.linalg.norm(rad, axis=1, keepdims=True)
        dr = (d * rad).sum(1)
        und = cv2.fisheye.undistortPoints(uv.reshape(-1, 1, 2).astype(np.float64), K, D).reshape(-1, 2)
        P = und * scene["distance"]  # the marker plane, fronto-parallel at the true distance
        r = circle(P) if v["radius_mm"] is not None else math.inf
        # Each dot's error normal to the true arc (outward from its centre), um.
        Q = cv2.fisheye.undistortPoints(tp.reshape(-1, 1, 2).astype(np.float64), K, D).reshape(-1, 2) \
            * scene["distance"]
        if v["radius_mm"] is None:
            nrm = np.tile([0.0, 1.0], (len(Q), 1))
        else:
            x, y = Q[:, 0], Q[:, 1]
            cx, cy, _ = np.linalg.lstsq(np.c_[2 * x, 2 * y, np.ones_like(x)], x * x + y * y, rcond=None)[0]
            nrm = (Q - [cx, cy]) / np.linalg.norm(Q - [cx, cy], axis=1, keepdims=True)
        r_mm = circle(np.array([np.mean(mm[v["file"]][k], axis=0) for k in sorted(m)])) \
            if v["radius_mm"] is not None else math.inf
        normal_um = " ".join(f"{e:+5.1f}" for e in 1000 * ((P - Q) * nrm).sum(1))
        k_meas = 1000.0 / r
        dk = k_meas - v["curvature_per_m"]
        # Sign: the curvature's sign from the circle's side is lost; report magnitudes.
        rt = "inf" if v["radius_mm"] is None else f"{v['radius_mm']:.3f}"
        print(f"{v['pressure_kpa']:5g} {rt:>9} {r:20.3f} {dk:+8.4f} {d[:, 0].mean():+10.3f} "
              f"{d[:, 1].mean():+10.3f} {np.abs(d).max():10.3f} {dr.mean():+11.3f} {r_mm:16.3f}  {normal_um}")


main()
