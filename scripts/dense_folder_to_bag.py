#!/usr/bin/env python3
"""Writes an MVSNet dense folder (as written by amhmvs_synthetic) as a ROS 1 bag
with the topics of the bags in ../shared/data/bags, plus ground-truth depth:

  /camera/image_raw    sensor_msgs/Image rgb8, frame camera_optical
  /camera/camera_info  sensor_msgs/CameraInfo (plumb_bob, zero distortion)
  /camera/pose         geometry_msgs/PoseStamped, camera-to-world, frame world
  /tf                  tf2_msgs/TFMessage, world -> camera_optical
  /camera/depth_gt     sensor_msgs/Image 32FC1, z-depth in metres, NaN = nothing
                       (only when DENSE_DIR/depth_gt/ exists)

View N gets the stamp START + N * PERIOD. The output depends only on the
folder and the options (no wall-clock time), so equal inputs give equal bags.

usage: dense_folder_to_bag.py DENSE_DIR OUTPUT.bag [--period 0.5] [--start 1700000000]
"""
import argparse
import contextlib
import os
import sys

import cv2
import numpy as np
import rosbag
import rospy
from geometry_msgs.msg import PoseStamped, TransformStamped
from sensor_msgs.msg import CameraInfo, Image
from tf2_msgs.msg import TFMessage

FIXED_FRAME = "world"
OPTICAL_FRAME = "camera_optical"


@contextlib.contextmanager
def bag_written_atomically(path):
    """A rosbag.Bag that writes to a hidden file beside `path` and is renamed
    onto it once closed: an interrupted or failed run leaves no half bag under
    the name (and the previous bag, if any, whole)."""
    folder, name = os.path.split(os.path.abspath(path))
    partial = os.path.join(folder, '.%s.%d.tmp' % (name, os.getpid()))
    try:
        with rosbag.Bag(partial, "w") as bag:
            yield bag
        os.replace(partial, path)
    finally:
        if os.path.exists(partial):
            os.remove(partial)


def read_cam(path):
    """World-to-camera 4x4 and K 3x3 of an MVSNet cam.txt."""
    words = open(path).read().split()
    try:
        extrinsic = np.array(words[words.index("extrinsic") + 1:][:16], dtype=float).reshape(4, 4)
        intrinsic = np.array(words[words.index("intrinsic") + 1:][:9], dtype=float).reshape(3, 3)
    except (ValueError, IndexError) as error:
        sys.exit(f"{path}: not an MVSNet cam file ({error})")
    return extrinsic, intrinsic


def read_pfm(path):
    """Single-channel PFM as a float32 array, top row first."""
    with open(path, "rb") as f:
        magic = f.readline().strip()
        if magic != b"Pf":
            sys.exit(f"{path}: not a single-channel PFM (magic {magic!r})")
        width, height = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=width * height)
    if data.size != width * height:
        sys.exit(f"{path}: truncated PFM")
    return np.flipud(data.reshape(height, width)).astype(np.float32)  # PFM rows run bottom-up


def quaternion_xyzw(rotation):
    """Unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method)."""
    m = rotation
    trace = np.trace(m)
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0] * 4
        q[i] = 0.25 * s
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
        q[3] = (m[k, j] - m[j, k]) / s
    q = np.array(q)
    return q / np.linalg.norm(q)


def quaternion_matrix(q):
    """Rotation matrix (nested lists) of a unit quaternion with fields x, y, z, w
    (geometry_msgs Quaternion): the inverse of quaternion_xyzw."""
    x, y, z, w = q.x, q.y, q.z, q.w
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def image_msg(array, encoding, header):
    msg = Image(header=header, height=array.shape[0], width=array.shape[1], encoding=encoding,
                is_bigendian=0)
    msg.step = array.strides[0]
    msg.data = array.tobytes()
    return msg


def camera_info_msg(intrinsic, width, height, header):
    fx, fy, cx, cy = intrinsic[0, 0], intrinsic[1, 1], intrinsic[0, 2], intrinsic[1, 2]
    return CameraInfo(header=header, width=width, height=height, distortion_model="plumb_bob",
                      D=[0.0] * 5, K=[fx, 0, cx, 0, fy, cy, 0, 0, 1], R=[1, 0, 0, 0, 1, 0, 0, 0, 1],
                      P=[fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0])


def pose_and_tf(camera_to_world, index, stamp):
    """PoseStamped (frame world) and the world -> camera_optical TFMessage of a
    4x4 camera-to-world pose."""
    pose = PoseStamped(header=rospy.Header(seq=index, stamp=stamp, frame_id=FIXED_FRAME))
    position, orientation = camera_to_world[:3, 3], quaternion_xyzw(camera_to_world[:3, :3])
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position
    (pose.pose.orientation.x, pose.pose.orientation.y, pose.pose.orientation.z,
     pose.pose.orientation.w) = orientation
    transform = TransformStamped(header=pose.header, child_frame_id=OPTICAL_FRAME)
    transform.transform.translation.x, transform.transform.translation.y, \
        transform.transform.translation.z = position
    transform.transform.rotation = pose.pose.orientation
    return pose, TFMessage(transforms=[transform])


def view_names(dense_dir):
    names = sorted(name[:-len("_cam.txt")] for name in os.listdir(os.path.join(dense_dir, "cams"))
                   if name.endswith("_cam.txt"))
    if not names:
        sys.exit(f"{dense_dir}/cams: no NNNNNNNN_cam.txt files")
    return names


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dense_dir")
    parser.add_argument("bag")
    parser.add_argument("--period", type=float, default=0.5, help="seconds between views (default 0.5)")
    parser.add_argument("--start", type=float, default=1700000000.0, help="stamp of the first view")
    args = parser.parse_args()

    names = view_names(args.dense_dir)
    depth_dir = os.path.join(args.dense_dir, "depth_gt")
    with_depth = os.path.isdir(depth_dir)
    with bag_written_atomically(args.bag) as bag:
        for index, name in enumerate(names):
            image_path = os.path.join(args.dense_dir, "images", name + ".png")
            bgr = cv2.imread(image_path, cv2.IMREAD_COLOR)
            if bgr is None:
                sys.exit(f"{image_path}: missing or unreadable")
            world_to_camera, intrinsic = read_cam(os.path.join(args.dense_dir, "cams", name + "_cam.txt"))
            camera_to_world = np.linalg.inv(world_to_camera)
            stamp = rospy.Time.from_sec(args.start + index * args.period)
            header = rospy.Header(seq=index, stamp=stamp, frame_id=OPTICAL_FRAME)
            height, width = bgr.shape[:2]

            pose, tf = pose_and_tf(camera_to_world, index, stamp)

            bag.write("/tf", tf, stamp)
            bag.write("/camera/pose", pose, stamp)
            bag.write("/camera/camera_info", camera_info_msg(intrinsic, width, height, header), stamp)
            bag.write("/camera/image_raw", image_msg(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), "rgb8", header), stamp)
            if with_depth:
                depth = read_pfm(os.path.join(depth_dir, name + ".pfm"))
                if depth.shape != (height, width):
                    sys.exit(f"{depth_dir}/{name}.pfm: {depth.shape[1]}x{depth.shape[0]}, image is {width}x{height}")
                bag.write("/camera/depth_gt", image_msg(depth, "32FC1", header), stamp)
    print(f"wrote {args.bag}: {len(names)} views, {width}x{height}, {args.period} s apart"
          f"{', with /camera/depth_gt' if with_depth else ''}")


if __name__ == "__main__":
    main()
