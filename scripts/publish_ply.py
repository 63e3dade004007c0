#!/usr/bin/env python3
"""Publishes a PLY cloud (as written by the demo) once, latched, as a
PointCloud2 with x y z rgb in ~frame_id (default world) on `cloud`, with a
static tf that makes ~frame_id known; then spins until shut down (for rviz
pictures of a saved map).

usage: publish_ply.py MAP.ply [_frame_id:=world] [cloud:=/topic]
"""
import os
import sys

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import PointCloud2, PointField

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from demo_outputs import read_ply  # noqa: E402


def cloud_msg(xyz, rgb, frame_id):
    points = np.empty(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    for i, name in enumerate("xyz"):
        points[name] = xyz[:, i]
    rgb = rgb.astype(np.uint32)
    points["rgb"] = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    fields = [PointField(name, 4 * i, PointField.FLOAT32, 1) for i, name in enumerate(("x", "y", "z", "rgb"))]
    msg = PointCloud2(height=1, width=len(points), fields=fields, is_bigendian=False, point_step=16,
                      row_step=16 * len(points), is_dense=True, data=points.tobytes())
    msg.header.frame_id = frame_id
    msg.header.stamp = rospy.Time.now()
    return msg


def main():
    argv = rospy.myargv()
    if len(argv) != 2:
        sys.exit(__doc__)
    rospy.init_node("publish_ply", anonymous=True)
    xyz, rgb = read_ply(argv[1])
    publisher = rospy.Publisher("cloud", PointCloud2, queue_size=1, latch=True)
    msg_frame = rospy.get_param("~frame_id", "world")
    publisher.publish(cloud_msg(xyz, rgb, msg_frame))
    # rviz warns about a fixed frame that tf does not know: announce it.
    frame = TransformStamped(child_frame_id=msg_frame + "_ply")
    frame.header.frame_id, frame.header.stamp, frame.transform.rotation.w = msg_frame, rospy.Time.now(), 1.0
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(frame)
    rospy.loginfo("published %d points of %s on %s", len(xyz), argv[1], publisher.resolved_name)
    rospy.spin()


if __name__ == "__main__":
    main()
