#!/usr/bin/env python3
"""rostest checker: a missing or silent input topic is never "OK". With images
arriving, camera_info advertised but silent and no publisher on pose, the
nodelet's diagnostics go WARN naming both resolved topics, and its log says
so; once image, camera_info and pose all arrive in sync, the status is OK
again."""
import sys
import time
import unittest

import rosbag
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image

from node_watch import NodeWatch

WARN, OK = 1, 0


class SilentInputs(unittest.TestCase):
    def test_silent_and_missing_topics_warn_by_name(self):
        rospy.init_node('check_silent_inputs')
        watch = NodeWatch(rospy.get_param('~node', '/amhmvs/mapping'))
        logged = []
        rospy.Subscriber('/rosout', Log, lambda m: logged.append(m.msg) if m.level >= Log.WARN else None)
        first = {}
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
                first.setdefault(topic, msg)
        image, info, pose = first['/camera/image_raw'], first['/camera/camera_info'], first['/camera/pose']

        # Nobody publishes yet: WARN, every input topic named.
        self.assertTrue(watch.wait_for(lambda: watch.level == WARN and 'no publisher on /camera/pose' in watch.message
                                       and 'no publisher on /camera/image_raw' in watch.message, 20), watch.message)

        image_pub = rospy.Publisher('/camera/image_raw', Image, queue_size=10)
        info_pub = rospy.Publisher('/camera/camera_info', CameraInfo, queue_size=10)
        self.assertTrue(watch.wait_for(lambda: image_pub.get_num_connections() > 0 and
                                       info_pub.get_num_connections() > 0, 20))

        def publish_for(seconds, with_info, pose_pub=None):
            end = time.time() + seconds
            while time.time() < end:
                stamp = rospy.Time.now()
                image.header.stamp = info.header.stamp = pose.header.stamp = stamp
                image_pub.publish(image)
                if with_info:
                    info_pub.publish(info)
                if pose_pub:
                    pose_pub.publish(pose)
                time.sleep(0.2)

        # Images only: camera_info silent, pose without a publisher.
        publish_for(2.5, with_info=False)
        self.assertTrue(watch.wait_for(lambda: watch.level == WARN and 'nothing on /camera/camera_info' in watch.message
                                       and 'no publisher on /camera/pose' in watch.message, 10), watch.message)
        self.assertTrue(watch.wait_for(lambda: any('/camera/camera_info' in line for line in logged), 10), logged)
        self.assertEqual(watch.count('frames_received'), 0)

        # Everything in sync: OK again (the same pose: one keyframe, no drops).
        pose_pub = rospy.Publisher('/camera/pose', PoseStamped, queue_size=10)
        self.assertTrue(watch.wait_for(lambda: pose_pub.get_num_connections() > 0, 20))
        publish_for(3.0, with_info=True, pose_pub=pose_pub)
        self.assertTrue(watch.wait_for(lambda: watch.level == OK, 5), watch.message)
        self.assertGreater(watch.count('frames_received'), 0)
        self.assertEqual(watch.count('keyframes_sent'), 1)  # the pose never moves


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'silent_inputs', SilentInputs, sys.argv)
