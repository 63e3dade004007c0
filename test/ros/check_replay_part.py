#!/usr/bin/env python3
"""rostest checker (replay_part.test): mapping.launch's bag arguments play
only [start, start + duration] of the bag at `rate` times its speed, and the
nodelet publishes the view frame that the shipped rviz config uses as its
fixed frame and view target (z the world's up); demo.launch,
replay_bag.launch and mapping.launch pass rate, start and duration to rosbag
play (-r, -s, -u), and rviz gets the view frame or the fixed frame asked for."""
import math
import os
import subprocess
import sys
import time
import unittest

import numpy as np
import rosbag
import rospy
import rostest
import tf2_ros
import yaml
from sensor_msgs.msg import CameraInfo

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from dense_folder_to_bag import quaternion_matrix  # noqa: E402  (the bag writer's own conversion)


def node_command(node, launch_file, *args):
    """The command line roslaunch would run for `node` (roslaunch --args)."""
    return subprocess.check_output(['roslaunch', '--args', node, 'amhmvs_mapping', launch_file] + list(args),
                                   text=True).split()


class ReplayPart(unittest.TestCase):
    # test_1 first: the bag plays a few seconds after the launch.
    def test_1_part_of_the_bag_at_the_rate_and_the_view_frame(self):
        rospy.init_node('check_replay_part')
        rate, start, duration = (rospy.get_param('~' + name) for name in ('rate', 'start', 'duration'))
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            stamps = [msg.header.stamp.to_sec() for _, msg, _ in bag.read_messages(['/camera/camera_info'])]
        first = stamps[0]
        expected = [s for s in stamps if first + start - 1e-3 <= s <= first + start + duration + 1e-3]
        received = []  # (stamp, wall time)
        rospy.Subscriber('/camera/camera_info', CameraInfo,
                         lambda msg: received.append((msg.header.stamp.to_sec(), time.time())))
        deadline = time.time() + 60
        # Until the player has been quiet for 3 s after the part.
        while time.time() < deadline and not (received and time.time() - received[-1][1] > 3):
            time.sleep(0.1)
        got = [stamp for stamp, _ in received]
        rospy.loginfo('check_replay_part: %d of %d frames played, stamps %s (bag from %.1f)', len(got),
                      len(stamps), ['%.1f' % (s - first) for s in got], first)
        self.assertGreaterEqual(len(expected), 3)
        self.assertLess(len(expected), len(stamps))
        # rosbag play -u stops at the part's end; a frame exactly there may be left out.
        self.assertTrue(set(got) <= set(expected), 'frames outside the part: %s' % sorted(set(got) - set(expected)))
        self.assertGreaterEqual(len(got), len(expected) - 1)
        stamp_span = got[-1] - got[0]
        wall_span = received[-1][1] - received[0][1]
        self.assertGreater(stamp_span, 0)
        # At rate 2 the part plays in half its bag time (1x would be 1.0).
        self.assertLess(wall_span / stamp_span, 0.8, 'wall %.2f s for %.2f s of bag' % (wall_span, stamp_span))
        self.assertGreater(wall_span / stamp_span, 0.3, 'wall %.2f s for %.2f s of bag' % (wall_span, stamp_span))

        # The view frame: where the first keyframe with depth looks.
        with open(rospy.get_param('~rviz_config')) as f:
            view = yaml.safe_load(f)['Visualization Manager']['Views']['Current']
        view_frame = rospy.get_param('/amhmvs/mapping/view_frame')
        self.assertEqual(view['Target Frame'], view_frame)
        with open(rospy.get_param('~rviz_config')) as f:
            self.assertEqual(yaml.safe_load(f)['Visualization Manager']['Global Options']['Fixed Frame'], view_frame)
        buffer = tf2_ros.Buffer()
        self.listener = tf2_ros.TransformListener(buffer)  # kept alive for the test
        transform = None
        while transform is None and time.time() < deadline + 60:
            try:
                transform = buffer.lookup_transform('world', view_frame, rospy.Time(0))
            except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException):
                time.sleep(0.2)
        self.assertIsNotNone(transform, 'no %s frame in tf' % view_frame)
        t = transform.transform.translation
        self.assertTrue(all(math.isfinite(v) for v in (t.x, t.y, t.z)))
        # Its z is the world's up (view_up auto): world z or a signed world axis.
        up = np.array(quaternion_matrix(transform.transform.rotation))[:, 2]
        self.assertAlmostEqual(float(np.linalg.norm(up)), 1.0, places=6)
        self.assertAlmostEqual(float(np.max(np.abs(up))), 1.0, places=6, msg='up %s is not a world axis' % up)
        rospy.loginfo('check_replay_part: %s at (%.2f, %.2f, %.2f), z along (%.2f, %.2f, %.2f)', view_frame,
                      t.x, t.y, t.z, *up)

    def test_2_bag_part_arguments_reach_rosbag_play(self):
        # demo.launch, replay_bag.launch and mapping.launch pass rate, start and duration to rosbag play.
        part = ['bag:=/tmp/part.bag', 'rate:=0.5', 'start:=12', 'duration:=30']
        for launch_file, extra in (('demo.launch', ['output_dir:=/tmp/out', 'expected_frames:=3']),
                                   ('replay_bag.launch', []), ('mapping.launch', [])):
            command = ' '.join(node_command('/player', launch_file, *(part + extra)))
            self.assertIn('-r 0.5 -s 12 -u 30', command, launch_file)
            self.assertIn('--clock', command, launch_file)
            self.assertTrue(command.split(' __name')[0].endswith('/tmp/part.bag'), command)
        whole = ' '.join(node_command('/player', 'replay_bag.launch', 'bag:=/tmp/part.bag'))
        self.assertIn('-r 1.0 -s 0 /tmp/part.bag', whole)  # no -u: to the end
        nodes = subprocess.check_output(['roslaunch', '--nodes', 'amhmvs_mapping', 'mapping.launch'], text=True)
        self.assertNotIn('/player', nodes)  # no bag: nothing played

    def test_3_rviz_gets_the_view_frame_or_the_fixed_frame_asked_for(self):
        for extra, frame in (([], 'amhmvs_view'), (['rviz_fixed_frame:=odom'], 'odom')):
            command = node_command('/rviz', 'mapping.launch', 'rviz:=true', *extra)
            self.assertIn('-f', command)
            self.assertEqual(command[command.index('-f') + 1], frame)


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'check_replay_part', ReplayPart, sys.argv)
