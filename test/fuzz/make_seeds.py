#!/usr/bin/python3
"""Seed corpora for the fuzz targets of test/fuzz, made from the shared data
($AMHMVS_DATA_DIR): small crops of real PFM/PNG/JPEG files, real MVSNet cam
and pair files, and COLMAP models (text and binary) and PLY files built from
the fountain's real cameras. Written at test time (no copies in the repository).

Usage: make_seeds.py DATA_DIR OUT_DIR  -> OUT_DIR/<fuzz target>/<seed files>
"""
import glob
import os
import struct
import sys

import cv2
import numpy as np

SEPARATOR = b"\n--8<--\n"  # fuzz_input.h: splitParts()
SIZE = (64, 48)  # the header-only images of fuzz_colmap.cpp


def write(out, target, name, data):
    os.makedirs(os.path.join(out, target), exist_ok=True)
    with open(os.path.join(out, target, name), "wb") as f:
        f.write(data)


def pfm(image, little_endian=True):
    channels = 3 if image.ndim == 3 else 1
    header = b"%s\n%d %d\n%s\n" % (b"PF" if channels == 3 else b"Pf", image.shape[1], image.shape[0],
                                   b"-1.0" if little_endian else b"1.0")
    data = np.flipud(image).astype("<f4" if little_endian else ">f4")
    return header + data.tobytes()


def image_seeds(data, out):
    for i, path in enumerate(sorted(glob.glob(os.path.join(data, "middlebury2014", "*", "disp0GT.pfm")))[:2]):
        with open(path, "rb") as f:
            f.readline(), f.readline()
            scale = float(f.readline())
            full = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
        crop = full[: 12 * 16].reshape(12, 16)
        write(out, "fuzz_pfm", "gray%d.pfm" % i, pfm(crop))
        write(out, "fuzz_pfm", "gray_be%d.pfm" % i, pfm(crop, little_endian=False))
        write(out, "fuzz_pfm", "rgb%d.pfm" % i, pfm(np.dstack([crop] * 3)[:4, :4]))
    color = cv2.imread(os.path.join(data, "middlebury2014", "Piano", "im0.png"))
    small = cv2.resize(color, (16, 12), interpolation=cv2.INTER_AREA)
    gray = cv2.cvtColor(small, cv2.COLOR_BGR2GRAY)
    for ext, img in ((".png", small), (".jpg", small), (".bmp", small), (".pgm", gray), (".ppm", small)):
        ok, encoded = cv2.imencode(ext, img)
        write(out, "fuzz_image_header", "piano" + ext, encoded.tobytes())
    ok, encoded = cv2.imencode(".pgm", gray.astype(np.uint16) * 257)  # maxval 65535
    write(out, "fuzz_image_header", "piano16.pgm", encoded.tobytes())
    # Headers of the full-size real files (the sizers read only the start).
    for path in sorted(glob.glob(os.path.join(data, "redkitchen_7scenes", "*.jpg")))[:1] + \
            [os.path.join(data, "mvsnet", "fountain_x0.25", "images", "00000000.png")]:
        with open(path, "rb") as f:
            write(out, "fuzz_image_header", "head_" + os.path.basename(path), f.read(2048))


def read_cam(path):
    lines = [l.split() for l in open(path) if l.strip()]
    extrinsic = np.array([[float(v) for v in l] for l in lines[1:5]])
    intrinsic = np.array([[float(v) for v in l] for l in lines[6:9]])
    depth = [float(v) for v in lines[9]]
    return extrinsic, intrinsic, depth


def quaternion(r):
    w = np.sqrt(max(1e-12, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    return [w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w)]


def colmap_seeds(data, out):
    folder = os.path.join(data, "mvsnet", "fountain_x0.25")
    cams = sorted(glob.glob(os.path.join(folder, "cams", "*_cam.txt")))
    for path in cams[:6]:
        write(out, "fuzz_mvsnet_cam", os.path.basename(path), open(path, "rb").read())
    write(out, "fuzz_mvsnet_pair", "fountain_pair.txt", open(os.path.join(folder, "pair.txt"), "rb").read())
    for name in ("middlebury2014_Piano",):
        write(out, "fuzz_mvsnet_pair", name + "_pair.txt",
              open(os.path.join(data, "mvsnet", name, "pair.txt"), "rb").read())

    # Four fountain cameras, K scaled to 64x48, and points at mid-depth in
    # front of every camera, seen by all four.
    views = [read_cam(p) for p in cams[:4]]
    width0 = 2 * views[0][1][0, 2]
    s = SIZE[0] / width0
    points = []
    for extrinsic, _, depth in views:
        r, t = extrinsic[:3, :3], extrinsic[:3, 3]
        centre = -r.T @ t
        for k in range(12):
            z = depth[0] + (k + 1) * (depth[-1] - depth[0]) / 14
            points.append(centre + r.T @ np.array([0.01 * k, -0.01 * k, z]))
    cams_txt, images_txt, points_txt = ["# Camera list\n"], ["# Image list\n"], ["# 3D point list\n"]
    cams_bin = struct.pack("<Q", len(views))
    images_bin = struct.pack("<Q", len(views))
    points_bin = struct.pack("<Q", len(points))
    for i, (extrinsic, k, _) in enumerate(views):
        fx, fy, cx, cy = k[0, 0] * s, k[1, 1] * s, (k[0, 2] + 0.5) * s - 0.5, (k[1, 2] + 0.5) * s - 0.5
        cams_txt.append("%d PINHOLE %d %d %r %r %r %r\n" % (i + 1, SIZE[0], SIZE[1], fx, fy, cx, cy))
        cams_bin += struct.pack("<IiQQ4d", i + 1, 1, SIZE[0], SIZE[1], fx, fy, cx, cy)
        q, t = quaternion(extrinsic[:3, :3]), extrinsic[:3, 3]
        images_txt.append("%d %s %d %d.pgm\n\n" % (i + 1, " ".join(repr(v) for v in list(q) + list(t)), i + 1, i))
        images_bin += struct.pack("<I7dI", i + 1, *q, *t, i + 1) + b"%d.pgm\0" % i + struct.pack("<Q", 0)
    for p, xyz in enumerate(points):
        track = " ".join("%d 0" % (i + 1) for i in range(len(views)))
        points_txt.append("%d %r %r %r 128 128 128 0.5 %s\n" % (p + 1, *xyz, track))
        points_bin += struct.pack("<Q3d3Bd", p + 1, *xyz, 128, 128, 128, 0.5) + struct.pack("<Q", len(views))
        points_bin += b"".join(struct.pack("<II", i + 1, 0) for i in range(len(views)))
    text = SEPARATOR.join("".join(part).encode() for part in (cams_txt, images_txt, points_txt))
    write(out, "fuzz_colmap_text", "fountain4.txt", text)
    write(out, "fuzz_colmap_binary", "fountain4.bin", SEPARATOR.join((cams_bin, images_bin, points_bin)))

    # PLY: the same points, ASCII and binary, with the attributes readPly knows.
    header = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n"
              "property uchar green\nproperty uchar blue\nproperty float quality\nend_header\n")
    ascii_rows = "".join("%r %r %r 0 0 -1 200 100 50 0.5\n" % tuple(p) for p in points)
    write(out, "fuzz_ply", "fountain_ascii.ply", (header % ("ascii", len(points)) + ascii_rows).encode())
    binary = (header % ("binary_little_endian", len(points))).encode()
    binary += b"".join(struct.pack("<6f3Bf", *p, 0, 0, -1, 200, 100, 50, 0.5) for p in points)
    write(out, "fuzz_ply", "fountain_binary.ply", binary)
    write(out, "fuzz_ply", "face_first.ply",
          b"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty int f\nelement vertex 1\n"
          b"property double x\nproperty double y\nproperty double z\nend_header\n" +
          struct.pack("<i3d", 7, *points[0]))


def ros_seeds(out):
    # FuzzedDataProvider input: any bytes; a few lengths give different shapes.
    for n in (16, 64, 256, 1024):
        write(out, "fuzz_ros_conversions", "bytes%d" % n, bytes((i * 37) % 256 for i in range(n)))


def main():
    data, out = sys.argv[1], sys.argv[2]
    image_seeds(data, out)
    colmap_seeds(data, out)
    ros_seeds(out)


if __name__ == "__main__":
    main()
