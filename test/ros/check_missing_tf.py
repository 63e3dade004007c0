#!/usr/bin/env python3
"""rostest checker: tf input mode without the transform. Images whose
fixed_frame <- optical frame transform never comes are dropped after
~tf_timeout and counted (missing_tf), without blocking the nodelet; once the
transform is broadcast, frames are accepted again, also a frame whose
transform comes after it (it waits in the nodelet's tf message filter)."""
import sys
import time
import unittest

import rosbag
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import CameraInfo, Image

from node_watch import NodeWatch

FRAMES_WITHOUT_TF = 3
LATE_TF = 0.5  # seconds


class MissingTf(unittest.TestCase):
    def test_missing_tf_dropped_and_counted(self):
        rospy.init_node('check_missing_tf')
        watch = NodeWatch(rospy.get_param('~node', '/amhmvs/mapping'))
        image_pub = rospy.Publisher('/camera/image_raw', Image, queue_size=10)
        info_pub = rospy.Publisher('/camera/camera_info', CameraInfo, queue_size=10)
        broadcaster = tf2_ros.TransformBroadcaster()
        buffer = tf2_ros.Buffer()
        self.listener = tf2_ros.TransformListener(buffer)  # kept alive for the test
        first, poses = {}, []
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
                first.setdefault(topic, msg)
                if topic == '/camera/pose':
                    poses.append(msg.pose)
        image, info = first['/camera/image_raw'], first['/camera/camera_info']
        self.assertTrue(watch.wait_for(lambda: image_pub.get_num_connections() > 0 and
                                       info_pub.get_num_connections() > 0 and watch.diagnostics, 30))

        def publish(stamp):
            image.header.stamp = info.header.stamp = stamp
            image_pub.publish(image)
            info_pub.publish(info)

        for k in range(FRAMES_WITHOUT_TF):
            publish(rospy.Time.now())
            # One at a time: the synchroniser pairs them, then the frame waits ~tf_timeout.
            self.assertTrue(watch.wait_for(lambda: watch.count('dropped: missing_tf') == k + 1, 10),
                            watch.diagnostics)
        self.assertEqual(watch.count('keyframes_received'), 0)

        def broadcast(stamp, pose):
            transform = TransformStamped()
            transform.header.stamp = stamp
            transform.header.frame_id = 'world'
            transform.child_frame_id = image.header.frame_id
            transform.transform.translation.x = pose.position.x
            transform.transform.translation.y = pose.position.y
            transform.transform.translation.z = pose.position.z
            transform.transform.rotation = pose.orientation
            broadcaster.sendTransform(transform)
            # On the wire once this checker's own listener has it.
            self.assertTrue(watch.wait_for(lambda: buffer.can_transform('world', transform.child_frame_id, stamp), 10))

        # With the transform: accepted (a keyframe, the first: no depth).
        stamp = rospy.Time.now()
        broadcast(stamp, poses[0])
        publish(stamp)
        self.assertTrue(watch.wait_for(lambda: watch.count('keyframes_received') == 1, 10), watch.diagnostics)
        self.assertEqual(watch.count('dropped: missing_tf'), FRAMES_WITHOUT_TF)

        # The transform LATE_TF seconds after its image (well within
        # ~tf_timeout, 3 s in missing_tf.test): the frame waits for it and is
        # accepted (the bag's next pose: a keyframe).
        stamp = rospy.Time.now()
        publish(stamp)
        time.sleep(LATE_TF)  # the delay under test, not a wait for a result
        broadcast(stamp, poses[1])
        self.assertTrue(watch.wait_for(lambda: watch.count('keyframes_received') == 2, 10), watch.diagnostics)
        self.assertEqual(watch.count('dropped: missing_tf'), FRAMES_WITHOUT_TF)


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'missing_tf', MissingTf, sys.argv)
