#!/usr/bin/env python3
"""A small SLAM adapter for the rostests: publishes the fountain bag's frames
as amhmvs_mapping/Keyframe messages (image, camera_info, camera-to-world pose,
and the sparse SIFT points each view observes, as a SLAM system's map points),
at the bag's 2 Hz, once the nodelet and the checker subscribe.

Parameters: ~bag, ~sparse_points, ~topic (default /keyframe), ~subscribers
(default 2: the nodelet and the checker), ~period (default 0.5 s)."""
import rosbag
import rospy
from geometry_msgs.msg import Point

from amhmvs_mapping.msg import Keyframe
import sparse_agreement


def main():
    rospy.init_node('fountain_keyframes')
    frames = {}
    with rosbag.Bag(rospy.get_param('~bag')) as bag:
        for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
            frames.setdefault(msg.header.stamp, {})[topic.split('/')[-1]] = msg
    sparse = sparse_agreement.read_sparse_points(rospy.get_param('~sparse_points'))
    pub = rospy.Publisher(rospy.get_param('~topic', '/keyframe'), Keyframe, queue_size=20)
    wanted = rospy.get_param('~subscribers', 2)
    while pub.get_num_connections() < wanted and not rospy.is_shutdown():
        rospy.sleep(0.1)
    period = rospy.get_param('~period', 0.5)
    for index, stamp in enumerate(sorted(frames)):
        frame = frames[stamp]
        kf = Keyframe()
        kf.header.stamp = stamp
        kf.header.frame_id = frame['pose'].header.frame_id
        kf.keyframe_id = index
        kf.image = frame['image_raw']
        kf.camera_info = frame['camera_info']
        kf.camera_to_world = frame['pose'].pose
        kf.sparse_points = [Point(*p) for p, views in sparse if index in views]
        pub.publish(kf)
        rospy.sleep(period)
    rospy.loginfo('fountain_keyframes: %d keyframes published', len(frames))
    rospy.spin()


if __name__ == '__main__':
    main()
