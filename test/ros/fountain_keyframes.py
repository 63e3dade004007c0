#!/usr/bin/env python3
"""A small SLAM adapter for the rostests: publishes the fountain bag's frames
as amhmvs_mapping/Keyframe messages (image, camera_info, camera-to-world pose,
and the sparse SIFT points each view observes, as a SLAM system's map points),
at the bag's 2 Hz, once the nodelet and the checker subscribe.

Parameters: ~bag, ~sparse_points, ~topic (default /keyframe), ~subscribers
(default 2: the nodelet and the checker), ~period (default 0.5 s).

read_frames() and keyframe_msg() also serve check_keyframe_services.py."""
import copy

import rosbag
import rospy
from geometry_msgs.msg import Point

from amhmvs_mapping.msg import Keyframe
import sparse_agreement


def read_frames(bag_path):
    """The bag's frames in stamp order: {'image_raw', 'camera_info', 'pose'} each."""
    frames = {}
    with rosbag.Bag(bag_path) as bag:
        for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
            frames.setdefault(msg.header.stamp, {})[topic.split('/')[-1]] = msg
    return [frames[stamp] for stamp in sorted(frames)]


def keyframe_msg(frame, view, keyframe_id, stamp, sparse):
    """Frame `view` of read_frames() as a Keyframe with the sparse points that
    view observes (no depth range: it comes from those points)."""
    kf = Keyframe()
    kf.header.stamp = stamp
    kf.header.frame_id = frame['pose'].header.frame_id
    kf.keyframe_id = keyframe_id
    kf.image = frame['image_raw']
    kf.camera_info = frame['camera_info']
    kf.camera_to_world = copy.deepcopy(frame['pose'].pose)
    kf.sparse_points = [Point(*p) for p, views in sparse if view in views]
    return kf


def main():
    rospy.init_node('fountain_keyframes')
    frames = read_frames(rospy.get_param('~bag'))
    sparse = sparse_agreement.read_sparse_points(rospy.get_param('~sparse_points'))
    pub = rospy.Publisher(rospy.get_param('~topic', '/keyframe'), Keyframe, queue_size=20)
    wanted = rospy.get_param('~subscribers', 2)
    while pub.get_num_connections() < wanted and not rospy.is_shutdown():
        rospy.sleep(0.1)
    period = rospy.get_param('~period', 0.5)
    for index, frame in enumerate(frames):
        pub.publish(keyframe_msg(frame, index, index, frame['image_raw'].header.stamp, sparse))
        rospy.sleep(period)
    rospy.loginfo('fountain_keyframes: %d keyframes published', len(frames))
    rospy.spin()


if __name__ == '__main__':
    main()
