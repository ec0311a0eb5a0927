#!/usr/bin/env python3
"""Physically based test footage for bendscope (issue 40, item 2).

Renders a PneuNets-like actuator (9 chambers with bellows gaps, a strain-limited bottom
layer) bent onto circles of known radius with Mitsuba 3 (CPU, `scalar_rgb`): a rough
silicone BSDF, red dots painted as a texture on the filmed side face (UV fixed in the
straight state, so the paint stretches with the surface), two area lights (soft shadows),
a clamp, a tube and a textured background. Each image is rendered through a wide pinhole
and remapped to a GoPro-like fisheye (OpenCV's Kannala-Brandt model), blurred, given
sensor noise and encoded as a GoPro would (H.264 High, yuv420p BT.709, ~40 Mbit/s, one
key frame a second). The calibration and scale photos are rendered the same way.

The truth is the bent position of each painted dot's centre: the radius of the circle
through them in the marker plane, per pressure, in `truth-pbr.json`.

This file shares no code with bendscope's own `render`; it only writes the session layout
`bendscope process` reads (videos, pressures.csv, calib/, scale.jpg, bendscope.toml).

Usage: render_session.py OUT [--seeds N] [--no-calib] [--png] [--unlit] [--flat]
                           [--mottle M] [--seed S] [--spp N] [--cache DIR]
Renders are cached in OUT/../pbr-cache (keyed on every scene parameter), so a rerun
only re-encodes what changed. The switches other than --seeds are the experiments of
docs/src/validation.md ("Physically based renders").
"""
import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import cv2

# ---------------------------------------------------------------------------
# Parameters (mm, px). Every choice the issue leaves open is here.
# ---------------------------------------------------------------------------

CAMERA = {
    # GoPro-like 1080p wide: Kannala-Brandt theta_d = theta (1 + k1 t^2 + k2 t^4 + ...)
    "width": 1920,
    "height": 1080,
    "fx": 880.0,
    "fy": 880.0,
    "cx": 963.2,
    "cy": 536.7,
    "k": [0.045, 0.012, -0.004, 0.0006],
}

ACTUATOR = {
    "length": 116.0,  # b
    "width": 15.0,  # i
    "base": 8.0,  # f + m: solid bottom layer plus channel, up to the channel roof
    "height": 23.5,  # a
    "end_chamber": 13.75,  # c
    "chamber": 11.5,  # g
    "gap": 1.0,  # d
    "n_chambers": 9,
    "fillet": 2.0,  # top edge rounding of each chamber (bellows look)
    "dot_diameter": 3.0,
    "dot_height": 15.75,  # dot centres on the side face: mid-height of the chamber wall
}

SCENE = {
    "distance": 250.0,  # camera centre to the marker plane (the filmed side face)
    "aim": [52.0, -22.0],  # x, z of the marker plane point on the optical axis
    "background_gap": 45.0,  # marker plane to the background sheet
    "spp": 48,
    "calib_spp": 16,
    "pinhole_f": 1000.0,  # focal length of the wide pinhole render, px
    "blur_sigma": 0.55,  # optical blur in fisheye px
    "noise_read": 1.5,  # 8-bit units
    "noise_shot": 0.034,  # shot noise variance per 8-bit unit of signal
    "exposure": 1.8,
    "fps": 30,
    "seconds": 2.0,
}

PRESSURES = [  # (kPa, radius of the bottom (neutral) layer, mm; None = straight)
    (0.0, None),
    (20.0, 400.0),
    (30.0, 200.0),
    (40.0, 126.0),
    (50.0, 90.0),
    (60.0, 68.0),
    (70.0, 55.0),
]

CALIB_BOARD = {"cols": 9, "rows": 6, "square": 25.0}
SCALE_BOARD = {"cols": 9, "rows": 6, "square": 10.0}
N_CALIB = 14


SEED = 0  # Mitsuba's sampler seed (--seed)
UNLIT = False  # --unlit: surfaces' albedo, no lighting at all (an experiment)


def log(*a):
    print("[pbr]", *a, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------
# Geometry: the straight actuator as quads, then bent.
# ---------------------------------------------------------------------------


def chambers():
    """x ranges of the 9 chambers."""
    a = ACTUATOR
    out, x = [], 0.0
    for k in range(a["n_chambers"]):
        g = a["end_chamber"] if k in (0, a["n_chambers"] - 1) else a["chamber"]
        out.append((x, x + g))
        x += g + a["gap"]
    return out


def dot_centres_straight():
    """Straight-state (x, y, z) of the 8 dots: side face, centre of chambers 2..9."""
    a = ACTUATOR
    y = a["width"] / 2
    return np.array([[(x0 + x1) / 2, y, a["dot_height"]] for (x0, x1) in chambers()[1:]])


def profile(x0, x1, z0, z1, r, step):
    """Chamber outline in x-z (a rectangle with rounded top corners), counter-clockwise
    from the bottom left, as points about `step` apart."""
    pts = []

    def seg(p, q):
        n = max(1, int(math.ceil(math.dist(p, q) / step)))
        for i in range(n):
            t = i / n
            pts.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))

    seg((x0, z0), (x1, z0))
    seg((x1, z0), (x1, z1 - r))
    n = 8
    for i in range(n):
        t = i / n * math.pi / 2
        pts.append((x1 - r + r * math.cos(t), z1 - r + r * math.sin(t)))
    seg((x1 - r, z1), (x0 + r, z1))
    for i in range(n):
        t = math.pi / 2 + i / n * math.pi / 2
        pts.append((x0 + r + r * math.cos(t), z1 - r + r * math.sin(t)))
    seg((x0, z1 - r), (x0, z0))
    return np.array(pts)


def prism(outline, y0, y1, step):
    """The walls of the x-z outline extruded from y0 to y1, as (V, F); `cap` closes the
    two ends."""
    n = len(outline)
    V, F = [], []
    ny = max(1, int(math.ceil((y1 - y0) / step)))
    ys = np.linspace(y0, y1, ny + 1)
    for j, y in enumerate(ys):
        for (x, z) in outline:
            V.append((x, y, z))
    for j in range(ny):
        for i in range(n):
            a_, b_ = j * n + i, j * n + (i + 1) % n
            c_, d_ = (j + 1) * n + (i + 1) % n, (j + 1) * n + i
            F += [(a_, b_, c_), (a_, c_, d_)]
    return np.array(V, float), np.array(F, int)


def cap(x0, x1, z0, z1, r, y, step, facing_plus):
    """A chamber's (or the base's) face at y as triangles: vertical strips from the
    bottom to the rounded top at each x, fine in x and z so it bends smoothly."""
    nx = max(2, int(math.ceil((x1 - x0) / step)))
    xs = np.linspace(x0, x1, nx + 1)
    ztop = np.full_like(xs, z1)
    for xc in (x0 + r, x1 - r):
        m = np.abs(xs - xc) <= r
        if xc == x0 + r:
            m &= xs < xc
        else:
            m &= xs > xc
        ztop[m] = z1 - r + np.sqrt(np.maximum(r * r - (xs[m] - xc) ** 2, 0))
    nz = max(1, int(math.ceil((z1 - z0) / step)))
    V = []
    for i, x in enumerate(xs):
        for j in range(nz + 1):
            V.append((x, y, z0 + (ztop[i] - z0) * j / nz))
    F = []
    for i in range(nx):
        for j in range(nz):
            a_ = i * (nz + 1) + j
            b_ = (i + 1) * (nz + 1) + j
            if facing_plus:
                F += [(a_, a_ + 1, b_ + 1), (a_, b_ + 1, b_)]
            else:
                F += [(a_, b_, b_ + 1), (a_, b_ + 1, a_ + 1)]
    return np.array(V, float), np.array(F, int)


def actuator_meshes(step=0.5):
    """(body, side face) meshes of the straight actuator: body = everything but the filmed
    side face (y = +width/2), which carries the dot texture."""
    a = ACTUATOR
    w2 = a["width"] / 2
    bodies, sides = [], []
    boxes = [(0.0, a["length"], 0.0, a["base"], 1e-3)] + [
        (x0, x1, a["base"] - 0.01, a["height"], a["fillet"]) for (x0, x1) in chambers()]
    for (x0, x1, z0, z1, r) in boxes:
        bodies.append(prism(profile(x0, x1, z0, z1, r, step), -w2, w2, step * 2))
        bodies.append(cap(x0, x1, z0, z1, r, -w2, step * 2, False))
        sides.append(cap(x0, x1, z0, z1, r, w2, step, True))
    return merge(bodies), merge(sides)


def merge(parts):
    V, F, off = [], [], 0
    for v, f in parts:
        V.append(v)
        F.append(f + off)
        off += len(v)
    return np.vstack(V), np.vstack(F)


def bend(P, radius, x_clamp):
    """Bends straight points onto a circle: the bottom layer (z = 0) becomes an arc of
    `radius` from the clamp face x_clamp; plane sections stay plane and normal to it,
    so a point at height z ends on the circle of radius + z. The centre of curvature is
    below (-z): the actuator curls toward its strain-limited bottom."""
    P = np.array(P, float)
    if radius is None:
        return P
    out = P.copy()
    s = P[:, 0] - x_clamp
    m = s > 0
    phi = s[m] / radius
    rho = radius + P[m, 2]
    out[m, 0] = x_clamp + rho * np.sin(phi)
    out[m, 2] = -radius + rho * np.cos(phi)
    return out


def truth_circle(points_xz):
    """Least-squares (geometric, here exact) circle through the bent dot centres."""
    x, z = points_xz[:, 0], points_xz[:, 1]
    A = np.c_[2 * x, 2 * z, np.ones_like(x)]
    b = x * x + z * z
    cx, cz, c = np.linalg.lstsq(A, b, rcond=None)[0]
    return math.sqrt(c + cx * cx + cz * cz)


# ---------------------------------------------------------------------------
# Textures.
# ---------------------------------------------------------------------------

SILICONE = np.array([0.80, 0.78, 0.74])
DOT = np.array([0.55, 0.035, 0.035])
PX_PER_MM = 40


def side_texture(path, mottle=0.03):
    """Dots on pale silicone, UV (x / length, z / height), with a faint mottling of the
    cast silicone (relative amplitude `mottle`); dot edges antialiased."""
    a = ACTUATOR
    W, H = int(a["length"] * PX_PER_MM), int(a["height"] * PX_PER_MM)
    u = (np.arange(W) + 0.5) / PX_PER_MM
    v = (np.arange(H) + 0.5) / PX_PER_MM
    X, Z = np.meshgrid(u, v)
    rng = np.random.default_rng(7)
    mott = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 12)
    mott = 1 + mottle * mott / (mott.std() + 1e-9)
    img = SILICONE[None, None, :] * mott[..., None]
    r = a["dot_diameter"] / 2
    for (x, _, z) in dot_centres_straight():
        d = np.hypot(X - x, Z - z)
        cov = np.clip((r - d) * PX_PER_MM + 0.5, 0, 1)
        img = img * (1 - cov[..., None]) + DOT[None, None, :] * cov[..., None]
    # Row 0 is v = 0 (z = 0): Mitsuba looks a PLY mesh's v up from the first row (checked
    # against the projected dot centres).
    write_linear_png(path, img)


def write_linear_png(path, img):
    """Writes a reflectance image as a 16-bit sRGB PNG (Mitsuba reads it as sRGB)."""
    srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * np.power(np.clip(img, 0, 1), 1 / 2.4) - 0.055)
    cv2.imwrite(path, (np.clip(srgb, 0, 1) * 65535 + 0.5).astype(np.uint16)[..., ::-1])


def background_texture(path):
    """A white sheet with a paper-like grain and a faint weave."""
    W, H = 3000, 2000
    rng = np.random.default_rng(11)
    g = rng.normal(0, 1, (H, W)).astype(np.float32)
    fine = cv2.GaussianBlur(g, (0, 0), 1.2)
    coarse = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 25)
    yy, xx = np.mgrid[0:H, 0:W]
    weave = 0.5 * (np.sin(xx / 3.1) * np.sin(yy / 3.3))
    t = 0.82 + 0.025 * fine / fine.std() + 0.03 * coarse / coarse.std() + 0.01 * weave
    img = np.stack([t * 0.98, t * 0.97, t * 0.93], -1)
    write_linear_png(path, img)


def board_texture(path, board):
    """A printed checkerboard (cols x rows inner corners, one square of white margin)."""
    s = board["square"]
    nx, ny = board["cols"] + 1, board["rows"] + 1
    ppm = 12 if s >= 20 else 24
    W, H = int((nx + 2) * s * ppm), int((ny + 2) * s * ppm)
    u = (np.arange(W) + 0.5) / ppm - s
    v = (np.arange(H) + 0.5) / ppm - s
    U, Vv = np.meshgrid(u, v)
    i, j = np.floor(U / s), np.floor(Vv / s)
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    black = inside & (((i + j) % 2) == 0)
    img = np.where(black, 0.04, 0.85).astype(np.float32)
    img = np.repeat(img[..., None], 3, -1)
    write_linear_png(path, img)
    return (nx + 2) * s, (ny + 2) * s


# ---------------------------------------------------------------------------
# Mitsuba scenes.
# ---------------------------------------------------------------------------


def write_ply(path, V, F, UV=None):
    V = np.asarray(V, np.float32)
    F = np.asarray(F, np.int32)
    with open(path, "wb") as f:
        hdr = ["ply", "format binary_little_endian 1.0", f"element vertex {len(V)}",
               "property float x", "property float y", "property float z"]
        if UV is not None:
            hdr += ["property float u", "property float v"]
        hdr += [f"element face {len(F)}", "property list uchar int vertex_indices", "end_header"]
        f.write(("\n".join(hdr) + "\n").encode())
        data = V if UV is None else np.hstack([V, np.asarray(UV, np.float32)])
        f.write(data.astype("<f4").tobytes())
        rec = np.zeros(len(F), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3
        rec["i"] = F
        f.write(rec.tobytes())


def camera_frame():
    """Camera centre and axes (right, down, forward) in world coordinates: in front of the
    marker plane (y = width/2), looking along -y, image x along world +x, image y along -z."""
    s = SCENE
    y_face = ACTUATOR["width"] / 2
    c = np.array([s["aim"][0], y_face + s["distance"], s["aim"][1]])
    right = np.array([1.0, 0.0, 0.0])
    down = np.array([0.0, 0.0, -1.0])
    fwd = np.array([0.0, -1.0, 0.0])
    return c, right, down, fwd


def project_fisheye(Pw):
    """World points -> fisheye pixels (OpenCV convention: pixel centres at integers)."""
    c, r, d, f = camera_frame()
    Q = (np.asarray(Pw) - c)
    X, Y, Z = Q @ r, Q @ d, Q @ f
    a, b = X / Z, Y / Z
    rr = np.hypot(a, b)
    th = np.arctan(rr)
    k = CAMERA["k"]
    thd = th * (1 + k[0] * th**2 + k[1] * th**4 + k[2] * th**6 + k[3] * th**8)
    sc = np.where(rr > 1e-12, thd / np.maximum(rr, 1e-12), 1.0)
    return np.c_[CAMERA["fx"] * a * sc + CAMERA["cx"], CAMERA["fy"] * b * sc + CAMERA["cy"]]


def fisheye_to_pinhole_norm(u, v):
    """Fisheye pixels -> normalized pinhole coordinates (x/z, y/z)."""
    xd = (u - CAMERA["cx"]) / CAMERA["fx"]
    yd = (v - CAMERA["cy"]) / CAMERA["fy"]
    thd = np.hypot(xd, yd)
    k = CAMERA["k"]
    th = thd.copy()
    for _ in range(20):
        f = th * (1 + k[0] * th**2 + k[1] * th**4 + k[2] * th**6 + k[3] * th**8) - thd
        df = 1 + 3 * k[0] * th**2 + 5 * k[1] * th**4 + 7 * k[2] * th**6 + 9 * k[3] * th**8
        th = th - f / df
    sc = np.where(thd > 1e-12, np.tan(th) / np.maximum(thd, 1e-12), 1.0)
    return xd * sc, yd * sc


def pinhole_window(ss):
    """The wide pinhole image that covers the whole fisheye frame (sampled ss times per
    fisheye pixel): its size and principal point, px."""
    W, H = CAMERA["width"], CAMERA["height"]
    u = np.r_[np.linspace(-0.5, W - 0.5, 200), np.full(200, -0.5), np.full(200, W - 0.5),
              np.linspace(-0.5, W - 0.5, 200)]
    v = np.r_[np.full(200, -0.5), np.linspace(-0.5, H - 0.5, 200), np.linspace(-0.5, H - 0.5, 200),
              np.full(200, H - 0.5)]
    x, y = fisheye_to_pinhole_norm(u, v)
    f = SCENE["pinhole_f"]
    x0, x1 = np.floor(x.min() * f) - 4, np.ceil(x.max() * f) + 4
    y0, y1 = np.floor(y.min() * f) - 4, np.ceil(y.max() * f) + 4
    return int(x1 - x0), int(y1 - y0), -x0, -y0


def sensor_dict(spp, crop=None):
    """A Mitsuba perspective sensor equal to the wide pinhole of `pinhole_window`: Mitsuba's
    film puts pixel (i, j)'s centre at (i + 0.5, j + 0.5) and the principal point at the
    film centre plus the offsets (fractions of the film size)."""
    import mitsuba as mi
    T = mi.ScalarTransform4f
    Wp, Hp, px, py = pinhole_window(1)
    f = SCENE["pinhole_f"]
    c, r, d, fw = camera_frame()
    fov = math.degrees(2 * math.atan(Wp / 2 / f))
    film = {"type": "hdrfilm", "width": Wp, "height": Hp, "rfilter": {"type": "gaussian", "stddev": 0.4},
            "pixel_format": "rgb", "sample_border": True}
    if crop:
        # crop = (x0, y0, w, h) in the flipped (final) image.
        film.update({"crop_offset_x": int(Wp - crop[0] - crop[2]), "crop_offset_y": int(crop[1]),
                     "crop_width": int(crop[2]), "crop_height": int(crop[3])})
    # Mitsuba's image of this look_at is mirrored left-right (its camera x points left):
    # render_pinhole flips it back; the offsets below put the principal point at (px, py)
    # of the flipped image (checked with point lights at known positions).
    return {
        "type": "perspective",
        "fov": fov,
        "fov_axis": "x",
        "principal_point_offset_x": (px - Wp / 2) / Wp,
        "principal_point_offset_y": (Hp / 2 - py) / Hp,
        "near_clip": 1.0,
        "far_clip": 5000.0,
        "to_world": T().look_at(origin=c.tolist(), target=(c + fw).tolist(), up=(-d).tolist()),
        "film": film,
        "sampler": {"type": "independent", "sample_count": spp, "seed": SEED},
    }


def lights(T):
    c = camera_frame()[0]
    return {
        "key": {"type": "rectangle",
                "to_world": T().look_at(origin=[c[0] - 160, 320, c[2] + 260], target=[50, 0, -20], up=[0, 0, 1]).scale(70),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [9.0, 8.8, 8.3]}}},
        "fill": {"type": "rectangle",
                 "to_world": T().look_at(origin=[c[0] + 260, 380, c[2] + 60], target=[50, 0, -20], up=[0, 0, 1]).scale(90),
                 "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [3.0, 3.0, 3.1]}}},
        "ambient": {"type": "constant", "radiance": {"type": "rgb", "value": [0.12, 0.12, 0.12]}},
    }


def silicone_bsdf(tex=None, flat=False):
    refl = {"type": "bitmap", "filename": tex, "filter_type": "bilinear"} if tex else \
        {"type": "rgb", "value": SILICONE.tolist()}
    if flat:
        return {"type": "diffuse", "reflectance": refl}
    return {"type": "roughplastic", "distribution": "ggx", "alpha": 0.35, "int_ior": 1.41,
            "diffuse_reflectance": refl, "nonlinear": False}


def base_scene(work, spp, crop=None, background_gap=None, with_clamp=True):
    """Background sheet, lights and (for the videos and the scale photo) the clamp and tube."""
    import mitsuba as mi
    T = mi.ScalarTransform4f
    y_face = ACTUATOR["width"] / 2
    gap = SCENE["background_gap"] if background_gap is None else background_gap
    bg = os.path.join(work, "background.png")
    if not os.path.exists(bg):
        background_texture(bg)
    sc = {
        "type": "scene",
        "integrator": {"type": "aov", "aovs": "alb:albedo"} if UNLIT else {"type": "path", "max_depth": 5},
        "sensor": sensor_dict(spp, crop),
        "background": {"type": "rectangle",
                       "to_world": T().translate([50, y_face - gap, -20]).rotate([1, 0, 0], -90).scale([1000, 750, 1]),
                       "bsdf": {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": bg}}},
    }
    sc.update(lights(T))
    if with_clamp:
        a = ACTUATOR
        x_c = chambers()[0][1] + 0.5
        sc["clamp_top"] = {"type": "cube",
                           "to_world": T().translate([(x_c - 30) / 2, 0, a["height"] + 4]).scale([(x_c + 30) / 2, 14, 4]),
                           "bsdf": {"type": "roughplastic", "alpha": 0.25,
                                    "diffuse_reflectance": {"type": "rgb", "value": [0.06, 0.06, 0.065]}}}
        sc["clamp_bottom"] = {"type": "cube",
                              "to_world": T().translate([(x_c - 30) / 2, 0, -4]).scale([(x_c + 30) / 2, 14, 4]),
                              "bsdf": {"type": "roughplastic", "alpha": 0.25,
                                       "diffuse_reflectance": {"type": "rgb", "value": [0.06, 0.06, 0.065]}}}
        sc["clamp_block"] = {"type": "cube",
                             "to_world": T().translate([-22, 0, a["height"] / 2]).scale([8, 14, a["height"] / 2 + 8]),
                             "bsdf": {"type": "roughplastic", "alpha": 0.3,
                                      "diffuse_reflectance": {"type": "rgb", "value": [0.35, 0.36, 0.38]}}}
        sc["tube"] = {"type": "cylinder", "p0": [-30, 0, 4.0], "p1": [-160, -10, 60], "radius": 3.0,
                      "bsdf": {"type": "roughplastic", "alpha": 0.15,
                               "diffuse_reflectance": {"type": "rgb", "value": [0.55, 0.6, 0.62]}}}
    return sc


def actuator_shapes(work, radius, flat=False, mottle=0.03):
    a = ACTUATOR
    key = "straight" if radius is None else f"r{radius:g}"
    body_ply = os.path.join(work, f"body-{key}.ply")
    side_ply = os.path.join(work, f"side-{key}.ply")
    tex = os.path.join(work, f"side-{mottle:g}.png")
    if not os.path.exists(tex):
        side_texture(tex, mottle)
    (Vb, Fb), (Vs, Fs) = actuator_meshes()
    x_clamp = chambers()[0][1] + 0.5
    UV = np.c_[Vs[:, 0] / a["length"], Vs[:, 2] / a["height"]]
    write_ply(body_ply, bend(Vb, radius, x_clamp), Fb)
    write_ply(side_ply, bend(Vs, radius, x_clamp), Fs, UV)
    return {
        "body": {"type": "ply", "filename": body_ply, "face_normals": True,
                 "bsdf": {"type": "twosided", "bsdf": silicone_bsdf(flat=flat)}},
        "side": {"type": "ply", "filename": side_ply, "face_normals": True,
                 "bsdf": {"type": "twosided", "bsdf": silicone_bsdf(tex, flat=flat)}},
    }


def board_shape(work, board, name, to_world_fn):
    import mitsuba as mi
    T = mi.ScalarTransform4f
    tex = os.path.join(work, f"{name}.png")
    bw, bh = board_texture(tex, board)
    s = board["square"]
    # Board local: the rectangle [-1,1]^2 scaled to the printed sheet; corner (0,0) of the
    # inner-corner grid sits at one square in from the margin, i.e. (s, s) from the sheet's
    # top left. to_world_fn maps board mm (x right, y down on the print, z toward viewer).
    M = to_world_fn(T) @ T().translate([bw / 2 - 2 * s, bh / 2 - 2 * s, 0]).scale([bw / 2, -bh / 2, 1])
    return {"type": "rectangle", "to_world": M, "flip_normals": False,
            "bsdf": {"type": "twosided", "bsdf": {"type": "roughplastic", "alpha": 0.5,
                     "diffuse_reflectance": {"type": "bitmap", "filename": tex, "filter_type": "bilinear"}}}}


def crop_of(points_world, margin_px):
    """The pinhole window (x0, y0, w, h) around world points, with a margin."""
    c, r, d, f = camera_frame()
    Q = np.asarray(points_world) - c
    z = Q @ f
    Wp, Hp, px, py = pinhole_window(1)
    fp = SCENE["pinhole_f"]
    u = (Q @ r) / z * fp + px
    v = (Q @ d) / z * fp + py
    x0 = int(max(0, math.floor(u.min() - margin_px)))
    y0 = int(max(0, math.floor(v.min() - margin_px)))
    x1 = int(min(Wp, math.ceil(u.max() + margin_px)))
    y1 = int(min(Hp, math.ceil(v.max() + margin_px)))
    return (x0, y0, x1 - x0, y1 - y0)


def render_composite(plate, scene_dict, cache_path, crop):
    """The scene rendered in the crop window, pasted into the plate (the same scene without
    the object, rendered once over the whole field), feathered over 16 px."""
    part = render_pinhole(scene_dict, cache_path)
    x0, y0, w, h = crop
    out = plate.copy()
    feather = 16
    wy = np.clip(np.minimum(np.arange(h), h - 1 - np.arange(h)) / feather, 0, 1)
    wx = np.clip(np.minimum(np.arange(w), w - 1 - np.arange(w)) / feather, 0, 1)
    m = (wy[:, None] * wx[None, :])[..., None]
    out[y0:y0 + h, x0:x0 + w] = m * part + (1 - m) * plate[y0:y0 + h, x0:x0 + w]
    return out


def render_pinhole(scene_dict, cache_path):
    if os.path.exists(cache_path):
        return np.load(cache_path)
    import mitsuba as mi
    t = time.time()
    scene = mi.load_dict(scene_dict)
    img = np.array(mi.render(scene), dtype=np.float32)[..., -3:]
    img = np.ascontiguousarray(img[:, ::-1] * (0.75 if UNLIT else 1.0))
    np.save(cache_path, img)
    log(f"rendered {os.path.basename(cache_path)} {img.shape[1]}x{img.shape[0]} in {time.time() - t:.0f} s")
    return img


# ---------------------------------------------------------------------------
# Camera: pinhole -> fisheye, blur, noise, tone.
# ---------------------------------------------------------------------------

SS = 2  # fisheye supersampling of the remap


def fisheye_maps():
    W, H = CAMERA["width"], CAMERA["height"]
    Wp, Hp, px, py = pinhole_window(1)
    f = SCENE["pinhole_f"]
    u = (np.arange(W * SS) + 0.5) / SS - 0.5
    v = (np.arange(H * SS) + 0.5) / SS - 0.5
    U, V = np.meshgrid(u, v)
    x, y = fisheye_to_pinhole_norm(U, V)
    # Pinhole pixel with centres at integers: continuous film coordinate minus 0.5.
    mx = (x * f + px - 0.5).astype(np.float32)
    my = (y * f + py - 0.5).astype(np.float32)
    return mx, my


_MAPS = None


def to_fisheye(pin):
    global _MAPS
    if _MAPS is None:
        _MAPS = fisheye_maps()
    big = cv2.remap(pin, _MAPS[0], _MAPS[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    img = cv2.resize(big, (CAMERA["width"], CAMERA["height"]), interpolation=cv2.INTER_AREA)
    if SCENE["blur_sigma"] > 0:
        img = cv2.GaussianBlur(img, (0, 0), SCENE["blur_sigma"])
    # Vignetting of the lens (cos^4-like falloff, mild as in a GoPro's processed output).
    H, W = img.shape[:2]
    yy, xx = np.mgrid[0:H, 0:W]
    r2 = ((xx - CAMERA["cx"]) ** 2 + (yy - CAMERA["cy"]) ** 2) / (CAMERA["fx"] ** 2)
    img = img * (1 - 0.12 * r2)[..., None]
    return img


def tone(lin, rng, noise=True):
    """Linear radiance -> 8-bit sRGB with shot and read noise."""
    x = np.clip(lin * SCENE["exposure"], 0, None)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    v = np.clip(srgb, 0, 1) * 255
    if noise:
        sd = np.sqrt(SCENE["noise_read"] ** 2 + SCENE["noise_shot"] * v)
        v = v + rng.normal(0, 1, v.shape) * sd
    return np.clip(v + 0.5, 0, 255).astype(np.uint8)


def encode(path, frames_rgb):
    H, W = frames_rgb[0].shape[:2]
    fps = SCENE["fps"]
    cmd = ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{W}x{H}",
           "-r", str(fps), "-i", "-", "-c:v", "libx264", "-profile:v", "high", "-preset", "medium",
           "-b:v", "40M", "-maxrate", "45M", "-bufsize", "40M", "-g", str(fps), "-bf", "2",
           "-vf", "scale=out_color_matrix=bt709:out_range=tv", "-pix_fmt", "yuv420p",
           "-colorspace", "bt709", "-color_primaries", "bt709", "-color_trc", "bt709", "-color_range", "tv",
           "-movflags", "+faststart", path]
    p = subprocess.Popen(cmd, stdin=subprocess.PIPE)
    for f in frames_rgb:
        p.stdin.write(np.ascontiguousarray(f).tobytes())
    p.stdin.close()
    if p.wait() != 0:
        raise SystemExit(f"ffmpeg failed on {path}")


# ---------------------------------------------------------------------------
# Calibration poses.
# ---------------------------------------------------------------------------


def rot(ax, deg):
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    if ax == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if ax == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def board_corners_cam(board, R, t):
    s = board["square"]
    g = np.array([[i * s, j * s, 0.0] for j in range(board["rows"]) for i in range(board["cols"])])
    return g @ R.T + t


def cam_to_world(Pc):
    c, r, d, f = camera_frame()
    return c + Pc[:, :1] * r + Pc[:, 1:2] * d + Pc[:, 2:3] * f


def calib_poses(n, seed=3):
    """Board poses in camera coordinates (x right, y down, z forward) that keep every
    corner inside the frame with a margin, spread over the field: a grid of aims and
    tilts up to 45 degrees, 240 to 420 mm away."""
    rng = np.random.default_rng(seed)
    b = CALIB_BOARD
    s = b["square"]
    centre = np.array([(b["cols"] - 1) * s / 2, (b["rows"] - 1) * s / 2, 0])
    poses = []
    targets = [(0, 0)] + [(math.cos(a), math.sin(a)) for a in np.linspace(0, 2 * math.pi, n, endpoint=False)]
    tries = 0
    while len(poses) < n and tries < 20000:
        tries += 1
        tx, ty = targets[len(poses) % len(targets)]
        reach = rng.uniform(0.5, 1.0) if len(poses) else 0.0
        th = math.atan(1.1) * reach
        dirv = np.array([math.tan(th) * tx, math.tan(th) * ty * 0.75, 1.0])
        dist = rng.uniform(240, 420)
        R = rot("x", rng.uniform(-40, 40)) @ rot("y", rng.uniform(-40, 40)) @ rot("z", rng.uniform(-20, 20))
        t = dirv / np.linalg.norm(dirv) * dist - R @ centre
        P = board_corners_cam(b, R, t)
        if (P[:, 2] < 80).any():
            continue
        # Face the camera.
        if (R @ np.array([0, 0, 1.0]))[2] > -0.2:
            R = R @ rot("x", 180)
            t = dirv / np.linalg.norm(dirv) * dist - R @ centre
            P = board_corners_cam(b, R, t)
            if (R @ np.array([0, 0, 1.0]))[2] > -0.2:
                continue
        uv = project_fisheye(cam_to_world(P))
        m = 60
        if (uv[:, 0] < m).any() or (uv[:, 0] > CAMERA["width"] - m).any() or (uv[:, 1] < m).any() or \
                (uv[:, 1] > CAMERA["height"] - m).any():
            continue
        poses.append((R, t))
    return poses


def pose_world_fn(R, t):
    """Board mm -> world, as a Mitsuba transform factory (board z toward the camera)."""
    c, r, d, f = camera_frame()
    Mw = np.c_[r, d, f]  # camera -> world rotation (columns)
    Rw = Mw @ R
    tw = c + Mw @ t

    def fn(T):
        m = np.eye(4)
        m[:3, :3] = Rw
        m[:3, 3] = tw
        return T(m.tolist())
    return fn


# ---------------------------------------------------------------------------
# Session.
# ---------------------------------------------------------------------------


def digest(obj):
    return hashlib.sha1(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:12]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out")
    ap.add_argument("--cache", default=None)
    ap.add_argument("--spp", type=int, default=SCENE["spp"])
    ap.add_argument("--seconds", type=float, default=SCENE["seconds"])
    ap.add_argument("--flat", action="store_true", help="diffuse dots and silicone, no highlights")
    ap.add_argument("--only", default=None, help="comma list of pressures (kPa) to render")
    ap.add_argument("--no-calib", action="store_true", help="videos only (calib/ and scale.jpg not written)")
    ap.add_argument("--mottle", type=float, default=0.03, help="relative mottling of the silicone's colour")
    ap.add_argument("--seed", type=int, default=0, help="Mitsuba's sampler seed (the first)")
    ap.add_argument("--seeds", type=int, default=1,
                    help="renders per pressure with successive seeds, cycled over the frames")
    ap.add_argument("--unlit", action="store_true", help="albedo only: no shading, no shadows")
    ap.add_argument("--png", action="store_true",
                    help="one noiseless PNG per pressure instead of a video (no noise, no H.264)")
    args = ap.parse_args()
    global SEED, UNLIT
    SEED = args.seed
    UNLIT = args.unlit
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    out = os.path.abspath(args.out)
    cache = os.path.abspath(args.cache or os.path.join(os.path.dirname(out), "pbr-cache"))
    os.makedirs(out, exist_ok=True)
    os.makedirs(cache, exist_ok=True)
    work = os.path.join(cache, "assets")
    os.makedirs(work, exist_ok=True)
    base_key = {"camera": CAMERA, "actuator": ACTUATOR, "scene": {k: v for k, v in SCENE.items()
                if k not in ("noise_read", "noise_shot", "seconds", "fps", "blur_sigma", "exposure")},
                "flat": args.flat, "spp": args.spp, "v": 1}
    if args.mottle != 0.03:
        base_key["mottle"] = args.mottle
    if args.seed:
        base_key["seed"] = args.seed
    if args.unlit:
        base_key["unlit"] = True
    rng = np.random.default_rng(2024)
    plate_spp = 8

    # Calibration photos and scale photo.
    if not args.no_calib:
        os.makedirs(os.path.join(out, "calib"), exist_ok=True)
        key = digest({"plate": "calib", "camera": CAMERA, "s": SCENE["pinhole_f"], "spp": plate_spp, "v": 1})
        plate = render_pinhole(base_scene(work, plate_spp, background_gap=600.0, with_clamp=False),
                               os.path.join(cache, f"plate-calib-{key}.npy"))
        poses = calib_poses(N_CALIB)
        for i, (R, t) in enumerate(poses):
            key = digest({"calib": CAMERA, "i": i, "R": R.tolist(), "t": t.tolist(),
                          "spp": SCENE["calib_spp"], "s": SCENE["pinhole_f"], "v": 1})
            b = CALIB_BOARD
            sq = b["square"]
            sheet = np.array([[x, y, 0.0] for x in (-2 * sq, (b["cols"] + 1) * sq)
                              for y in (-2 * sq, (b["rows"] + 1) * sq)])
            crop = crop_of(cam_to_world(sheet @ R.T + t), 24)
            sc = base_scene(work, SCENE["calib_spp"], crop=crop, background_gap=600.0, with_clamp=False)
            sc["board"] = board_shape(work, CALIB_BOARD, "calib-board", pose_world_fn(R, t))
            pin = render_composite(plate, sc, os.path.join(cache, f"calib{i:02d}-{key}.npy"), crop)
            img = tone(to_fisheye(pin), rng)
            cv2.imwrite(os.path.join(out, "calib", f"G{i + 1:07d}.JPG"), img[..., ::-1],
                        [cv2.IMWRITE_JPEG_QUALITY, 92])
        log(f"{len(poses)} calibration photos")

    # The plate has no actuator: the same for every variant of it.
    plate_key = {k: v for k, v in base_key.items() if k not in ("mottle", "seed")}
    plate_key.update({"flat": False, "spp": SCENE["spp"]})
    key = digest({"plate": plate_key, "spp": plate_spp})
    plate = render_pinhole(base_scene(work, plate_spp), os.path.join(cache, f"plate-video-{key}.npy"))
    if not args.no_calib:
        # Scale board: its printed face in the marker plane, beside the clamp.
        s = SCALE_BOARD["square"]
        y_face = ACTUATOR["width"] / 2
        origin = np.array([62.0 - 4 * s, y_face, -22.0 + 2.5 * s])

        def scale_fn(T):
            m = np.eye(4)
            m[:3, :3] = np.c_[[1, 0, 0], [0, 0, -1], [0, 1, 0]]
            m[:3, 3] = origin
            return T(m.tolist())
        key = digest({"scale": base_key, "o": origin.tolist(), "v": 1})
        sheet = origin + np.array([[x, 0, -z] for x in (-2 * s, 10 * s) for z in (-2 * s, 7 * s)])
        crop = crop_of(sheet, 100)
        sc = base_scene(work, args.spp, crop=crop)
        sc["board"] = board_shape(work, SCALE_BOARD, "scale-board", scale_fn)
        pin = render_composite(plate, sc, os.path.join(cache, f"scale-{key}.npy"), crop)
        cv2.imwrite(os.path.join(out, "scale.jpg"), tone(to_fisheye(pin), rng)[..., ::-1],
                    [cv2.IMWRITE_JPEG_QUALITY, 92])

    # Videos.
    only = None if args.only is None else {float(p) for p in args.only.split(",")}
    truth = []
    rows = []
    x_clamp = chambers()[0][1] + 0.5
    for i, (kpa, radius) in enumerate(PRESSURES):
        name = f"GX01{101 + i:04d}." + ("png" if args.png else "MP4")
        dots = bend(dot_centres_straight(), radius, x_clamp)
        r_truth = None if radius is None else truth_circle(dots[:, [0, 2]])
        uv = project_fisheye(dots)
        truth.append({"file": name, "pressure_kpa": kpa, "bottom_radius_mm": radius,
                      "radius_mm": r_truth, "curvature_per_m": 0.0 if radius is None else 1000.0 / r_truth,
                      "dots_mm": dots.tolist(), "dots_px": uv.tolist()})
        rows.append((name, kpa))
        if only is not None and kpa not in only:
            continue
        shapes = actuator_shapes(work, radius, flat=args.flat, mottle=args.mottle)
        (Vb, _), _ = actuator_meshes(step=2.0)
        crop = crop_of(np.vstack([bend(Vb, radius, x_clamp), [[-40, 0, 35], [-40, 0, -12]]]), 180)
        # One render per sampler seed; the frames cycle through them, so the renderer's
        # noise changes from frame to frame as a sensor's does instead of staying frozen.
        cleans = []
        for seed in range(args.seed, args.seed + args.seeds):
            SEED = seed
            vkey = {k: v for k, v in base_key.items() if k != "seed"}
            if seed:
                vkey["seed"] = seed
            key = digest({"video": vkey, "radius": radius})
            sc = base_scene(work, args.spp, crop=crop)
            sc.update(shapes)
            pin = render_composite(plate, sc, os.path.join(cache, f"video-{kpa:g}-{key}.npy"), crop)
            cleans.append(to_fisheye(pin))
        SEED = args.seed
        clean = sum(cleans) / len(cleans)
        n = max(1, int(round(args.seconds * SCENE["fps"])))
        if args.png:
            cv2.imwrite(os.path.join(out, name), tone(clean, rng, noise=False)[..., ::-1])
        else:
            encode(os.path.join(out, name), [tone(cleans[f % len(cleans)], rng) for f in range(n)])
        log(f"{name}: {kpa:g} kPa, truth R {r_truth}")
    with open(os.path.join(out, "pressures.csv"), "w") as f:
        f.write("file,pressure_kpa\n" + "".join(f"{n},{p:g}\n" for n, p in rows))
    with open(os.path.join(out, "bendscope.toml"), "w") as f:
        f.write("# Physically based render (scripts/pbr/render_session.py)\n"
                "model = \"fisheye\"\nexpected_markers = 8\n"
                f"[calib_board]\ncols = {CALIB_BOARD['cols']}\nrows = {CALIB_BOARD['rows']}\n"
                f"square_mm = {CALIB_BOARD['square']:g}\n"
                f"[scale_board]\ncols = {SCALE_BOARD['cols']}\nrows = {SCALE_BOARD['rows']}\n"
                f"square_mm = {SCALE_BOARD['square']:g}\n")
    with open(os.path.join(out, "truth-pbr.json"), "w") as f:
        json.dump({"camera": CAMERA, "scene": SCENE, "actuator": ACTUATOR, "videos": truth}, f, indent=1)
    write_true_calibration(os.path.join(out, "true-calibration.yaml"))


def write_true_calibration(path):
    c = CAMERA
    K = [c["fx"], 0, c["cx"], 0, c["fy"], c["cy"], 0, 0, 1]
    fmt = lambda a: ", ".join(f"{x:.10e}" for x in a)
    with open(path, "w") as f:
        f.write("%YAML:1.0\n---\nmodel: fisheye\n"
                f"image_width: {c['width']}\nimage_height: {c['height']}\n"
                "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                f"   data: [ {fmt(K)} ]\n"
                "distortion_coefficients: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n"
                f"   data: [ {fmt(c['k'])} ]\n")


if __name__ == "__main__":
    main()
