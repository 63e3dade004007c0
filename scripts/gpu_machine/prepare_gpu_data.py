#!/usr/bin/env python3
"""Prepares the real data for the GPU machine, which has Python with numpy and
OpenCV but no OpenCV C++: converts PNG/JPEG to PGM/PPM so that the ROS-free
core reads them, and makes the fountain x0.5 and x1 dense folders from the
Strecha originals (cameras and depth ranges of fountain_x0.25, K rescaled
about pixel centres; see ../shared/data/README.md).

usage: prepare_gpu_data.py SOURCE_DATA_DIR OUTPUT_DIR
"""
import os
import shutil
import sys

import cv2
import numpy as np


def to_pnm(src, dst):
    image = cv2.imread(src, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise SystemExit(f"cannot read {src}")
    if image.ndim == 3:
        image = cv2.cvtColor(image[:, :, :3], cv2.COLOR_BGR2RGB)
        cv2.imwrite(dst + ".ppm", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    else:
        cv2.imwrite(dst + ".pgm", image)


def convert_dense_folder(src, dst):
    os.makedirs(os.path.join(dst, "images"), exist_ok=True)
    shutil.copytree(os.path.join(src, "cams"), os.path.join(dst, "cams"), dirs_exist_ok=True)
    for name in ("pair.txt", "sparse_points.txt"):
        if os.path.exists(os.path.join(src, name)):
            shutil.copy(os.path.join(src, name), dst)
    for name in sorted(os.listdir(os.path.join(src, "images"))):
        to_pnm(os.path.join(src, "images", name), os.path.join(dst, "images", os.path.splitext(name)[0]))


def read_cam(path):
    lines = [l.split() for l in open(path) if l.strip()]
    extrinsic = np.array([[float(v) for v in lines[i]] for i in range(1, 5)])
    intrinsic = np.array([[float(v) for v in lines[i]] for i in range(6, 9)])
    depth = [float(v) for v in lines[9]]
    return extrinsic, intrinsic, depth


def write_cam(path, extrinsic, intrinsic, depth):
    with open(path, "w") as f:
        f.write("extrinsic\n")
        for row in extrinsic:
            f.write(" ".join(f"{v:.9g}" for v in row) + "\n")
        f.write("\nintrinsic\n")
        for row in intrinsic:
            f.write(" ".join(f"{v:.9g}" for v in row) + "\n")
        f.write("\n" + " ".join(f"{v:.9g}" for v in depth) + "\n")


def make_fountain(strecha, x025, dst, scale):
    os.makedirs(os.path.join(dst, "images"), exist_ok=True)
    os.makedirs(os.path.join(dst, "cams"), exist_ok=True)
    shutil.copy(os.path.join(x025, "pair.txt"), dst)
    for view in range(11):
        image = cv2.imread(os.path.join(strecha, "images", f"{view:04d}.jpg"), cv2.IMREAD_GRAYSCALE)
        h, w = image.shape
        size = (int(round(w * scale)), int(round(h * scale)))
        if scale != 1.0:
            image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        cv2.imwrite(os.path.join(dst, "images", f"{view:08d}.pgm"), image)
        extrinsic, k025, depth = read_cam(os.path.join(x025, "cams", f"{view:08d}_cam.txt"))
        # Undo the x0.25 scaling about pixel centres, then apply `scale`.
        k = k025.copy()
        s = scale / 0.25
        k[0, 0] *= s
        k[1, 1] *= s
        k[0, 2] = (k025[0, 2] + 0.5) * s - 0.5
        k[1, 2] = (k025[1, 2] + 0.5) * s - 0.5
        write_cam(os.path.join(dst, "cams", f"{view:08d}_cam.txt"), extrinsic, k, depth)


def main():
    src, dst = sys.argv[1], sys.argv[2]
    mvsnet = os.path.join(src, "mvsnet")
    for name in sorted(os.listdir(mvsnet)):
        convert_dense_folder(os.path.join(mvsnet, name), os.path.join(dst, "mvsnet", name))
    for scene in sorted(os.listdir(os.path.join(src, "middlebury2014"))):
        s = os.path.join(src, "middlebury2014", scene)
        d = os.path.join(dst, "middlebury2014", scene)
        os.makedirs(d, exist_ok=True)
        for name in ("calib.txt", "disp0GT.pfm"):
            shutil.copy(os.path.join(s, name), d)
        to_pnm(os.path.join(s, "mask0nocc.png"), os.path.join(d, "mask0nocc"))
    strecha = os.path.join(src, "strecha", "fountain-P11")
    if os.path.isdir(strecha):
        for scale, name in ((0.5, "fountain_x0.5"), (1.0, "fountain_x1")):
            make_fountain(strecha, os.path.join(mvsnet, "fountain_x0.25"),
                          os.path.join(dst, "mvsnet", name), scale)
    print(f"prepared {dst}")


if __name__ == "__main__":
    main()
