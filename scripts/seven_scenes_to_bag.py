#!/usr/bin/env python3
"""Writes frames of a 7-Scenes / tsdf-fusion folder (frame-NNNNNN.color.jpg,
.depth.png in mm, .pose.txt camera-to-world of the depth camera,
camera-intrinsics.txt of the depth camera) as a ROS 1 bag with the topics of
dense_folder_to_bag.py: /camera/image_raw (rgb8), /camera/camera_info,
/camera/pose and /tf of the COLOUR camera, and the ground truth of the
mapping rostest: /camera/depth_gt (32FC1, metres, NaN = nothing), the Kinect
depth reprojected into the colour camera (each depth pixel's point into the
nearest colour pixel, the nearest point wins), and /camera/pose_gt, the
folder's own pose of the colour camera. With --trajectory (a TUM file of the
depth camera's poses, stamp = file number / 30 as amhmvs_odometry writes it)
/camera/pose and /tf are that trajectory's: a real tracker's poses, with the
folder's kept as the truth.

Colour and depth of ../shared/data/redkitchen_7scenes are not registered: the
defaults are that data README's fitted colour camera (528, 528, 316, 238 at
640x480, centre 1 cm to the depth camera's left, same orientation). Frame N
gets the stamp START + N / RATE (the recording's 30 Hz by default).

usage: seven_scenes_to_bag.py FOLDER OUTPUT.bag [--count 40] [--stride 2] [--scale 0.5] [--trajectory TUM.txt]
"""
import argparse
import os
import re
import sys
from types import SimpleNamespace

import cv2
import numpy as np
import rospy

from dense_folder_to_bag import (OPTICAL_FRAME, bag_written_atomically, camera_info_msg, image_msg, pose_and_tf,
                                 quaternion_matrix)


def reprojected_depth(depth_mm, depth_k, color_k, offset, width, height):
    """z-depth (metres, NaN = nothing) of the colour camera: the depth camera's
    points moved by -offset (the colour centre in the depth frame) and
    projected, the nearest point per pixel."""
    valid = (depth_mm > 0) & (depth_mm < 65535)
    v, u = np.nonzero(valid)
    z = depth_mm[valid].astype(np.float64) / 1000.0
    x = (u - depth_k[0, 2]) / depth_k[0, 0] * z - offset[0]
    y = (v - depth_k[1, 2]) / depth_k[1, 1] * z - offset[1]
    z = z - offset[2]
    front = z > 0
    x, y, z = x[front], y[front], z[front]
    cu = np.rint(color_k[0, 0] * x / z + color_k[0, 2]).astype(int)
    cv = np.rint(color_k[1, 1] * y / z + color_k[1, 2]).astype(int)
    inside = (cu >= 0) & (cu < width) & (cv >= 0) & (cv < height)
    cu, cv, z = cu[inside], cv[inside], z[inside]
    out = np.full(height * width, np.inf)
    np.minimum.at(out, cv * width + cu, z)
    out[np.isinf(out)] = np.nan
    return out.reshape(height, width).astype(np.float32)


# amhmvs_odometry's stamps: file number / this (the sequence reader's 7-Scenes rate).
TRAJECTORY_FRAME_RATE = 30.0


def read_tum_trajectory(path):
    """{file number: 4x4 camera-to-world} of a TUM trajectory (stamp tx ty tz
    qx qy qz qw; '#' comments)."""
    poses = {}
    with open(path) as f:
        for line_number, line in enumerate(f, 1):
            fields = line.split('#')[0].split()
            if not fields:
                continue
            if len(fields) != 8:
                sys.exit(f"{path}:{line_number}: not 'stamp tx ty tz qx qy qz qw'")
            stamp, tx, ty, tz, qx, qy, qz, qw = (float(v) for v in fields)
            q = np.array([qx, qy, qz, qw])
            if not np.all(np.isfinite(q)) or abs(np.linalg.norm(q) - 1) > 1e-3:
                sys.exit(f"{path}:{line_number}: the quaternion is not a unit one")
            x, y, z, w = q / np.linalg.norm(q)
            pose = np.eye(4)
            pose[:3, :3] = quaternion_matrix(SimpleNamespace(x=x, y=y, z=z, w=w))
            pose[:3, 3] = [tx, ty, tz]
            poses[int(round(stamp * TRAJECTORY_FRAME_RATE))] = pose
    return poses


def colour_camera_pose(depth_to_world, offset):
    """The colour camera's camera-to-world: the depth camera's moved by offset."""
    camera_to_world = depth_to_world.copy()
    camera_to_world[:3, 3] += depth_to_world[:3, :3] @ offset
    return camera_to_world


def frame_numbers(folder):
    numbers = sorted(int(m.group(1)) for m in (re.fullmatch(r"frame-(\d+)\.color\.jpg", n) for n in os.listdir(folder))
                     if m)
    if not numbers:
        sys.exit(f"{folder}: no frame-NNNNNN.color.jpg")
    return numbers


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("bag")
    parser.add_argument("--first", type=int, default=0, help="index of the first frame file (default 0)")
    parser.add_argument("--count", type=int, default=40, help="frames written (default 40)")
    parser.add_argument("--stride", type=int, default=2, help="every STRIDE-th frame file (default 2)")
    parser.add_argument("--scale", type=float, default=0.5, help="image scale (default 0.5: 320x240)")
    parser.add_argument("--intrinsics", default="528,528,316,238", help="colour fx,fy,cx,cy at 640x480")
    parser.add_argument("--color_offset", default="-0.010,0,0",
                        help="colour camera centre in the depth camera frame, metres")
    parser.add_argument("--rate", type=float, default=30.0, help="frame numbers per second (default 30)")
    parser.add_argument("--start", type=float, default=1700000000.0, help="stamp of frame 0")
    parser.add_argument("--trajectory", help="TUM trajectory of the depth camera (amhmvs_odometry's) for "
                        "/camera/pose and /tf; /camera/pose_gt keeps the folder's")
    args = parser.parse_args()

    fx, fy, cx, cy = (float(v) for v in args.intrinsics.split(","))
    offset = np.array([float(v) for v in args.color_offset.split(",")])
    depth_k = np.loadtxt(os.path.join(args.folder, "camera-intrinsics.txt"))
    s = args.scale
    # scaled about pixel centres, as the core does: c' = (c + 0.5) s - 0.5
    color_k = np.array([[fx * s, 0, (cx + 0.5) * s - 0.5], [0, fy * s, (cy + 0.5) * s - 0.5], [0, 0, 1]])
    numbers = frame_numbers(args.folder)[args.first::args.stride][:args.count]
    tracked = read_tum_trajectory(args.trajectory) if args.trajectory else None
    if tracked is not None:
        missing = [n for n in numbers if n not in tracked]
        if missing:
            sys.exit(f"{args.trajectory}: no pose of frame {missing[0]} ({len(missing)} frames without one)")
    with bag_written_atomically(args.bag) as bag:
        for index, number in enumerate(numbers):
            prefix = os.path.join(args.folder, f"frame-{number:06d}")
            bgr = cv2.imread(prefix + ".color.jpg", cv2.IMREAD_COLOR)
            depth_mm = cv2.imread(prefix + ".depth.png", cv2.IMREAD_UNCHANGED)
            if bgr is None or depth_mm is None:
                sys.exit(f"{prefix}: colour or depth missing or unreadable")
            width, height = round(bgr.shape[1] * s), round(bgr.shape[0] * s)
            bgr = cv2.resize(bgr, (width, height), interpolation=cv2.INTER_AREA)
            true_pose = colour_camera_pose(np.loadtxt(prefix + ".pose.txt"), offset)
            camera_to_world = true_pose if tracked is None else colour_camera_pose(tracked[number], offset)

            stamp = rospy.Time.from_sec(args.start + number / args.rate)
            header = rospy.Header(seq=index, stamp=stamp, frame_id=OPTICAL_FRAME)
            pose, tf = pose_and_tf(camera_to_world, index, stamp)
            true_pose_msg, _ = pose_and_tf(true_pose, index, stamp)
            truth = reprojected_depth(depth_mm, depth_k, color_k, offset, width, height)
            bag.write("/tf", tf, stamp)
            bag.write("/camera/pose", pose, stamp)
            bag.write("/camera/pose_gt", true_pose_msg, stamp)
            bag.write("/camera/camera_info", camera_info_msg(color_k, width, height, header), stamp)
            bag.write("/camera/image_raw", image_msg(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), "rgb8", header), stamp)
            bag.write("/camera/depth_gt", image_msg(truth, "32FC1", header), stamp)
    print(f"wrote {args.bag}: {len(numbers)} frames ({numbers[0]}-{numbers[-1]}), {width}x{height}, "
          f"with /camera/depth_gt and /camera/pose_gt"
          + (f", poses of {args.trajectory}" if tracked is not None else ""))


if __name__ == "__main__":
    main()
