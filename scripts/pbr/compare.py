#!/usr/bin/env python3
"""Measured radii of `bendscope process` against the rendered truth, per pressure.

Usage: compare.py SESSION OUT [--label TEXT]
Reads SESSION/truth-pbr.json and OUT/per_video.csv; prints one row per pressure: truth
radius, measured radius, curvature error (measured - truth, 1/m) and radius error (%),
and the dot centroids' error against the projected true centres (markers.csv, px).
"""
import csv
import json
import math
import sys

import numpy as np


def main():
    session, out = sys.argv[1], sys.argv[2]
    label = sys.argv[4] if len(sys.argv) > 4 and sys.argv[3] == "--label" else None
    truth = {v["file"]: v for v in json.load(open(f"{session}/truth-pbr.json"))["videos"]}
    rows = list(csv.DictReader(open(f"{out}/per_video.csv")))
    px = {}
    try:
        for r in csv.DictReader(open(f"{out}/markers.csv")):
            px.setdefault(r["file"], {}).setdefault(int(r["marker"]), []).append(
                (float(r["x_px"]), float(r["y_px"])))
    except FileNotFoundError:
        pass
    if label:
        print(f"## {label}")
    print(f"{'kPa':>5} {'truth R mm':>10} {'measured R':>10} {'dk 1/m':>8} {'dR %':>7} "
          f"{'centroid err px (mean dx, dy; max)':>36}")
    worst = 0.0
    for r in rows:
        t = truth.get(r["file"])
        if t is None:
            continue
        rm = float(r["radius_mm"]) if r["radius_mm"] else math.nan
        k_true = t["curvature_per_m"]
        k_meas = 1000.0 / rm if rm == rm else math.nan
        dk = k_meas - k_true
        worst = max(worst, abs(dk)) if dk == dk else worst
        rt = t["radius_mm"]
        pct = "" if rt is None else f"{100 * (rm - rt) / rt:+7.3f}"
        cerr = ""
        if r["file"] in px:
            tp = np.array(t["dots_px"])
            m = px[r["file"]]
            if len(m) == len(tp):
                d = np.array([np.mean(m[k + 1], axis=0) - tp[k] for k in range(len(tp))])
                cerr = f"{d[:, 0].mean():+.3f}, {d[:, 1].mean():+.3f}; {np.abs(d).max():.3f}"
        print(f"{t['pressure_kpa']:5g} {('inf' if rt is None else f'{rt:.3f}'):>10} {rm:10.3f} "
              f"{dk:+8.4f} {pct:>7} {cerr:>36}")
    print(f"largest |curvature error| {worst:.4f} 1/m (goal 0.015)")


main()
