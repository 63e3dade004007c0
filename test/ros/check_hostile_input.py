#!/usr/bin/env python3
"""rostest checker: hostile Keyframe messages. Each malformed message is
dropped under its reason (diagnostics count it); a burst of 10,000 small
keyframes overflows the queue (drop-oldest, counted) while the store stays
within its keyframe bound and the node's memory stays bounded; afterwards a
good keyframe still gets its depth map (nothing crashed or hung)."""
import copy
import math
import sys
import time
import unittest

import rosbag
import rospy
import rostest
from amhmvs_mapping.msg import Keyframe
from sensor_msgs.msg import Image

from node_watch import NodeWatch, rss_mb

BURST = 10000
MAX_STORED = 20        # hostile_input.yaml store/max_keyframes
MAX_RSS_MB = 1024      # the node with ROS, OpenCV and PCL loaded is ~150-300 MB


class HostileInput(unittest.TestCase):
    def test_hostile_messages_are_counted_and_bounded(self):
        rospy.init_node('check_hostile_input')
        node = rospy.get_param('~node', '/amhmvs/mapping')
        watch = NodeWatch(node)
        depth_stamps = []
        rospy.Subscriber('/amhmvs/depth/image', Image, lambda m: depth_stamps.append(m.header.stamp.to_sec()))
        publisher = rospy.Publisher('/keyframe', Keyframe, queue_size=100)
        published = [0]

        class Counting:  # every message published, so that the node's counts can add up to it
            def publish(self, msg):
                published[0] += 1
                publisher.publish(msg)

            def get_num_connections(self):
                return publisher.get_num_connections()
        pub = Counting()
        frames = {}
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
                frames.setdefault(topic, []).append(msg)
        self.assertTrue(watch.wait_for(lambda: pub.get_num_connections() > 0 and watch.diagnostics, 30))
        stamp = [1000.0]

        def keyframe(index, kf_id):
            kf = Keyframe()
            stamp[0] += 1.0
            kf.header.stamp = rospy.Time.from_sec(stamp[0])
            kf.header.frame_id = 'world'
            kf.keyframe_id = kf_id
            kf.image = copy.deepcopy(frames['/camera/image_raw'][index])
            kf.camera_info = copy.deepcopy(frames['/camera/camera_info'][index])
            kf.camera_to_world = copy.deepcopy(frames['/camera/pose'][index].pose)
            kf.min_depth, kf.max_depth = 4.0, 20.0
            return kf

        # Each hostile message and the reason it must be counted under.
        cases = []
        kf = keyframe(0, 100)
        kf.image.data = kf.image.data[:len(kf.image.data) // 2]        # shorter than step x height
        cases.append(('dropped: bad_keyframe', kf))
        kf = keyframe(0, 101)
        kf.image.width = kf.image.height = kf.camera_info.width = kf.camera_info.height = 0
        kf.image.step, kf.image.data = 0, b''
        cases.append(('dropped: bad_camera_info', kf))                   # zero size
        kf = keyframe(0, 102)
        kf.image.width = kf.camera_info.width = 100000                   # huge, with a small buffer
        kf.image.height = kf.camera_info.height = 100000
        kf.image.step = 3 * 100000
        cases.append(('dropped: bad_keyframe', kf))
        for field, index in (('K', 0), ('D', 0), ('P', 0)):
            kf = keyframe(0, 103)
            values = list(getattr(kf.camera_info, field)) or [0.0] * 5
            values[index] = math.nan
            setattr(kf.camera_info, field, values)
            cases.append(('dropped: bad_camera_info', kf))               # NaN in K, D, P
        kf = keyframe(0, 104)
        kf.camera_info.distortion_model, kf.camera_info.D = 'made_up_model', [0.1, 0, 0, 0, 0]
        cases.append(('dropped: bad_keyframe', kf))                      # unknown distortion model
        kf = keyframe(0, 105)
        q = kf.camera_to_world.orientation
        q.x = q.y = q.z = q.w = 0.0
        cases.append(('dropped: bad_pose', kf))                          # zero-norm quaternion
        kf = keyframe(0, 106)
        kf.header.stamp = rospy.Time(0)
        cases.append(('dropped: bad_stamp', kf))                         # zero stamp
        kf = keyframe(0, 107)
        kf.header.stamp = rospy.Time.from_sec(rospy.Time.now().to_sec() + 10 * 86400)
        cases.append(('dropped: bad_stamp', kf))                         # far future

        expected = {}
        for reason, msg in cases:
            expected[reason] = expected.get(reason, 0) + 1
            pub.publish(msg)
            time.sleep(0.05)
        self.assertTrue(watch.wait_for(lambda: all(watch.count(r) == n for r, n in expected.items()), 30),
                        'expected %s, diagnostics %s' % (expected, watch.diagnostics))
        self.assertEqual(watch.count('keyframes_received'), 0, watch.diagnostics)

        # A burst of small keyframes: the queue drops the oldest (counted);
        # the store keeps at most its bound; memory stays bounded.
        small = keyframe(1, 0)
        small.image.width = small.camera_info.width = 32
        small.image.height = small.camera_info.height = 24
        small.image.step = 32 * 3
        small.image.data = bytes(range(256)) * (32 * 24 * 3 // 256)
        small.camera_info.K = [30, 0, 15.5, 0, 30, 11.5, 0, 0, 1]
        small.camera_info.D = []
        for i in range(BURST):
            small.keyframe_id = 1000 + i
            stamp[0] += 0.01
            small.header.stamp = rospy.Time.from_sec(stamp[0])
            small.camera_to_world.position.x += 0.01
            pub.publish(small)
        self.assertTrue(watch.wait_for(lambda: watch.diagnostics.get('idle') == 'True' and
                                       watch.count('frames_received') >= 1000, 120), watch.diagnostics)
        stored = watch.count('stored_keyframes')
        rss = rss_mb(node)
        rospy.loginfo('check_hostile_input: after the burst: %d frames received, %d dropped from the queue, '
                      '%d stored, RSS %.0f MB', watch.count('frames_received'), watch.count('dropped: queue_full'),
                      stored, rss)
        self.assertGreater(watch.count('dropped: queue_full'), 0)
        self.assertLessEqual(stored, MAX_STORED)
        self.assertLess(rss, MAX_RSS_MB)

        # Still alive: a good keyframe pair gets its depth map.
        good = [keyframe(0, 50000), keyframe(1, 50001)]
        for kf in good:
            pub.publish(kf)
        self.assertTrue(watch.wait_for(lambda: good[1].header.stamp.to_sec() in depth_stamps, 60),
                        watch.diagnostics)

        # Every message published reached the node or is counted lost before
        # it (the burst overflows the subscriber's queue, or rospy's own);
        # the diagnostics that follow the last depth image have the last counts.
        def counts():
            return ([watch.count(k) for k in watch.diagnostics if k.startswith('received on ')],
                    [watch.count(k) for k in watch.diagnostics if k.startswith('lost on ')])
        watch.wait_for(lambda: sum(sum(c) for c in counts()) >= published[0], 10)
        received, lost = counts()
        rospy.loginfo('check_hostile_input: %d published, %s received, %s lost before the subscriber',
                      published[0], received, lost)
        self.assertEqual(len(received), 1, watch.diagnostics)
        self.assertEqual(received[0] + lost[0], published[0], watch.diagnostics)
        self.assertEqual(lost[0], watch.count('dropped: before_subscriber'))


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'hostile_input', HostileInput, sys.argv)
