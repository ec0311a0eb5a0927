#!/usr/bin/env python3
"""Writes RealSense-layout ROS1 bags from a rendered RGB-D PNG session, with `rosbags`
(an independent bag writer: bendscope only reads bags).

    make-bag-fixtures.py PNG_SESSION OUT_DIR

PNG_SESSION is `bendscope render --rgbd`'s SESSION/rgbd (color/, depth/ aligned to
colour, intrinsics.json, pressure_log.csv, truth.json). Writes into OUT_DIR, each a
session folder (recording.bag + pressure_log.csv):

  lz4/       lz4 chunks; depth camera = the colour camera, identity extrinsics, the PNG
             depth frames as they are (so a bag measures exactly like the PNG folder)
  bz2/       the same with bz2 chunks
  baseline/  lz4 chunks; a depth camera of its own (other intrinsics, 15 mm baseline,
             a small rotation) whose depth is computed for its own view of the scene
             plane (fitted to the PNG depth); truth.json copied
  nodepth/   bz2, colour stream only (2 frames): the reader must refuse it

Topics as librealsense's ros_writer names them (src/media/ros/ros_file_format.h):
/device_0/sensor_0/Depth_0/..., /device_0/sensor_1/Color_0/... (image/data,
info/camera_info, tf/0), /device_0/sensor_0/option/Depth Units/value, /file_version.
tf/0 holds the extrinsics from the reference (pin) stream, depth, to the stream:
p_stream = R p_depth + t. Header stamps: 1700000000 s + frame / fps (depth 3 ms later);
record times the same.
"""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
from PIL import Image
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS1_NOETIC)
T = TS.types
T0_NS = 1_700_000_000 * 10**9
DEPTH_LAG_NS = 3_000_000

# The baseline bag's depth camera and its extrinsics depth -> colour.
BASELINE_DEPTH_K = (430.0, 431.0, 318.2, 241.7)  # fx fy cx cy
BASELINE_DEPTH_SIZE = (640, 480)
BASELINE_T_M = np.array([0.015, 0.0004, -0.0006])
BASELINE_ROT_DEG = (-0.3, 0.8, 0.2)  # about x, y, z


def rot(ax_deg, ay_deg, az_deg):
    ax, ay, az = np.radians([ax_deg, ay_deg, az_deg])
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


def quat(r):
    """Rotation matrix -> quaternion (x, y, z, w) (w > 0)."""
    w = np.sqrt(1.0 + r[0, 0] + r[1, 1] + r[2, 2]) / 2.0
    return ((r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w)


def header(seq, stamp_ns, frame):
    return T['std_msgs/msg/Header'](
        seq=seq,
        stamp=T['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9),
        frame_id=frame,
    )


def camera_info(w, h, k, stamp_ns):
    fx, fy, cx, cy = k
    return T['sensor_msgs/msg/CameraInfo'](
        header=header(0, stamp_ns, ''),
        height=h,
        width=w,
        distortion_model='Brown Conrady',
        D=np.zeros(5),
        K=np.array([fx, 0, cx, 0, fy, cy, 0, 0, 1], dtype=np.float64),
        R=np.eye(3).ravel(),
        P=np.array([fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0], dtype=np.float64),
        binning_x=0,
        binning_y=0,
        roi=T['sensor_msgs/msg/RegionOfInterest'](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )


def transform(r, t):
    x, y, z, w = quat(r)
    return T['geometry_msgs/msg/Transform'](
        translation=T['geometry_msgs/msg/Vector3'](x=float(t[0]), y=float(t[1]), z=float(t[2])),
        rotation=T['geometry_msgs/msg/Quaternion'](x=x, y=y, z=z, w=w),
    )


def image(seq, stamp_ns, pixels, encoding):
    h, w = pixels.shape[:2]
    data = np.ascontiguousarray(pixels).view(np.uint8).ravel()
    return T['sensor_msgs/msg/Image'](
        header=header(seq, stamp_ns, ''),
        height=h,
        width=w,
        encoding=encoding,
        is_bigendian=0,
        step=data.size // h,
        data=data,
    )


def write_bag(path, compression, frames, color_k, depth_k, depth_size, color_size, extr, unit_m, with_depth=True):
    """frames: [(rgb HxWx3 uint8, depth HxW uint16 or None)], colour at 10 fps."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        path.unlink()
    w = Writer(path)
    w.set_compression(compression)
    w.open()
    conns = {}

    def put(topic, msgtype, msg, t_ns):
        if topic not in conns:
            conns[topic] = w.add_connection(topic, msgtype, typestore=TS)
        w.write(conns[topic], t_ns, TS.serialize_ros1(msg, msgtype))

    put('/file_version', 'std_msgs/msg/UInt32', T['std_msgs/msg/UInt32'](data=3), T0_NS)
    cw, ch = color_size
    put('/device_0/sensor_1/Color_0/info/camera_info', 'sensor_msgs/msg/CameraInfo', camera_info(cw, ch, color_k, T0_NS), T0_NS)
    put('/device_0/sensor_1/Color_0/tf/0', 'geometry_msgs/msg/Transform', transform(*extr), T0_NS)
    if with_depth:
        dw, dh = depth_size
        put('/device_0/sensor_0/option/Depth Units/value', 'std_msgs/msg/Float32', T['std_msgs/msg/Float32'](data=unit_m), T0_NS)
        put('/device_0/sensor_0/Depth_0/info/camera_info', 'sensor_msgs/msg/CameraInfo', camera_info(dw, dh, depth_k, T0_NS), T0_NS)
        put('/device_0/sensor_0/Depth_0/tf/0', 'geometry_msgs/msg/Transform', transform(np.eye(3), np.zeros(3)), T0_NS)
    for i, (rgb, depth) in enumerate(frames):
        t = T0_NS + i * 100_000_000
        put('/device_0/sensor_1/Color_0/image/data', 'sensor_msgs/msg/Image', image(i, t, rgb, 'rgb8'), t)
        if with_depth:
            put('/device_0/sensor_0/Depth_0/image/data', 'sensor_msgs/msg/Image', image(i, t + DEPTH_LAG_NS, depth, '16UC1'), t + DEPTH_LAG_NS)
    w.close()


def main():
    src, out = Path(sys.argv[1]), Path(sys.argv[2])
    intr = json.loads((src / 'intrinsics.json').read_text())
    assert intr['fps'] == 10.0, intr
    k = (intr['fx'], intr['fy'], intr['cx'], intr['cy'])
    size = (intr['width'], intr['height'])
    unit = intr['depth_scale_m']
    names = sorted(p.name for p in (src / 'color').glob('*.png'))
    assert [int(n[:-4]) for n in names] == list(range(len(names))), names
    frames = [
        (np.asarray(Image.open(src / 'color' / n).convert('RGB')), np.asarray(Image.open(src / 'depth' / n)).astype(np.uint16))
        for n in names
    ]
    same = (np.eye(3), np.zeros(3))
    for name, comp in [('lz4', Writer.CompressionFormat.LZ4), ('bz2', Writer.CompressionFormat.BZ2)]:
        write_bag(out / name / 'recording.bag', comp, frames, k, k, size, size, same, unit)
        shutil.copy(src / 'pressure_log.csv', out / name / 'pressure_log.csv')

    # The scene plane n . p = c (colour frame, m), fitted to the aligned PNG depth.
    d0 = frames[0][1].astype(np.float64) * unit
    v, u = np.mgrid[0 : size[1], 0 : size[0]]
    pts = np.stack([(u - k[2]) / k[0] * d0, (v - k[3]) / k[1] * d0, d0], axis=-1)[d0 > 0]
    centre = pts.mean(axis=0)
    n = np.linalg.svd(pts - centre, full_matrices=False)[2][2]
    c = n @ centre
    rms = np.sqrt(np.mean((pts @ n - c) ** 2))
    assert rms < 1e-4, f'PNG depth is not one plane (rms {rms} m)'
    # The depth camera's view of it: ray r_d = ((u-cx)/fx, (v-cy)/fy, 1) in the depth
    # frame is o + s R r_d in the colour frame (o = t), z_depth = s.
    r, t = rot(*BASELINE_ROT_DEG), BASELINE_T_M
    fx, fy, cx, cy = BASELINE_DEPTH_K
    dw, dh = BASELINE_DEPTH_SIZE
    v, u = np.mgrid[0:dh, 0:dw]
    rays = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u, dtype=np.float64)], axis=-1)
    s = (c - n @ t) / (rays @ (r.T @ n))
    depth = np.round(s / unit).clip(0, 65535).astype(np.uint16)
    baseline = [(rgb, depth) for rgb, _ in frames]
    write_bag(out / 'baseline' / 'recording.bag', Writer.CompressionFormat.LZ4, baseline, k, BASELINE_DEPTH_K, BASELINE_DEPTH_SIZE, size, (r, t), unit)
    for f in ['pressure_log.csv', 'truth.json']:
        shutil.copy(src / f, out / 'baseline' / f)

    write_bag(out / 'nodepth' / 'recording.bag', Writer.CompressionFormat.BZ2, frames[:2], k, k, size, size, same, unit, with_depth=False)
    shutil.copy(src / 'pressure_log.csv', out / 'nodepth' / 'pressure_log.csv')
    for p in sorted(out.glob('*/recording.bag')):
        print(f'{p}: {p.stat().st_size} bytes')


if __name__ == '__main__':
    main()
