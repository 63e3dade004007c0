#!/usr/bin/env python3
"""Publishes a PLY cloud (as written by the demo) once, latched, as a
PointCloud2 with x y z rgb in ~frame_id (default world) on `cloud` (and, for
a mesh, its triangles as a visualization_msgs/Marker TRIANGLE_LIST on
`mesh`), and a
static tf frame ~frame_id + "_view" at the cloud's median point whose z axis
is ~up (default 0,0,1; 0,-1,0 for a world that is a camera frame, as
7-Scenes' and KinectFusion's): a fixed frame for rviz in which any map is in
view and upright. Then spins until shut down (for rviz pictures of a saved
map).

usage: publish_ply.py MAP.ply [_frame_id:=world] [_up:=X,Y,Z] [cloud:=/topic] [mesh:=/topic]
"""
import os
import sys

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Point, TransformStamped
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker

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


def mesh_msg(xyz, rgb, triangles, frame_id):
    msg = Marker(type=Marker.TRIANGLE_LIST, action=Marker.ADD, ns="surface", id=0)
    msg.header.frame_id = frame_id
    msg.header.stamp = rospy.Time.now()
    msg.pose.orientation.w = 1
    msg.scale.x = msg.scale.y = msg.scale.z = 1
    msg.color.a = 1
    corners = triangles.reshape(-1)
    msg.points = [Point(*map(float, xyz[i])) for i in corners]
    msg.colors = [ColorRGBA(*(rgb[i] / 255.0), 1.0) for i in corners]
    return msg


def view_frame(parent, origin, up):
    """The static transform parent -> parent_view: at origin, its z axis along
    up (the shortest rotation from the parent's z; a half turn about x for -z)."""
    up = up / np.linalg.norm(up)
    half_way = np.append(np.cross([0.0, 0.0, 1.0], up), 1.0 + up[2])  # x y z w, unnormalised
    q = half_way / np.linalg.norm(half_way) if half_way[3] > 1e-9 else np.array([1.0, 0, 0, 0])
    frame = TransformStamped(child_frame_id=parent + "_view")
    frame.header.frame_id, frame.header.stamp = parent, rospy.Time.now()
    t, r = frame.transform.translation, frame.transform.rotation
    t.x, t.y, t.z = (float(v) for v in origin)
    r.x, r.y, r.z, r.w = (float(v) for v in q)
    return frame


def main():
    argv = rospy.myargv()
    if len(argv) != 2:
        sys.exit(__doc__)
    rospy.init_node("publish_ply", anonymous=True)
    xyz, rgb, triangles = read_ply(argv[1], with_faces=True)
    publisher = rospy.Publisher("cloud", PointCloud2, queue_size=1, latch=True)
    msg_frame = rospy.get_param("~frame_id", "world")
    publisher.publish(cloud_msg(xyz, rgb, msg_frame))
    if len(triangles):
        mesh_publisher = rospy.Publisher("mesh", Marker, queue_size=1, latch=True)
        mesh_publisher.publish(mesh_msg(xyz, rgb, triangles, msg_frame))
    up = np.array([float(v) for v in str(rospy.get_param("~up", "0,0,1")).split(",")])
    if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) == 0:
        sys.exit("publish_ply: ~up must be three numbers, not all zero (got %s)" % rospy.get_param("~up"))
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(view_frame(msg_frame, np.median(xyz, axis=0) if len(xyz) else np.zeros(3), up))
    rospy.loginfo("published %d points of %s on %s", len(xyz), argv[1], publisher.resolved_name)
    rospy.spin()


if __name__ == "__main__":
    main()
