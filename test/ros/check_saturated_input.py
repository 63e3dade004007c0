#!/usr/bin/env python3
"""rostest checker: a real bag played fast into the nodelet while every core
is busy (cpu_hog.py beside the nodelet's own estimation). Once the input has
ended and the nodelet is idle, every message the bag holds is accounted for:
on each input topic, received by the subscriber or counted lost before it
(gaps in the publisher's numbering); every image a frame or unsynchronised;
every frame under one outcome; every keyframe sent received by the pipeline,
and there a first depth map, stored without sources, or dropped under its
reason."""
import collections
import os
import sys
import unittest

import rosbag
import rospy
import rostest

from node_watch import NodeWatch

# With keyframes_sent, every frame received (pose mode).
FRAME_OUTCOMES = ['keyframes_sent', 'frames_not_keyframes', 'frames_refused_pure_rotation',
                  'frames_refused_blurred', 'ignored_while_paused', 'dropped: encoding', 'dropped: bad_pose',
                  'dropped: bad_camera_info', 'dropped: bad_keyframe', 'dropped: stamp_backwards',
                  'dropped: bad_stamp']
# What became of a keyframe the pipeline received, beside its first depth map.
PIPELINE_DROPS = ['dropped: queue_full', 'dropped: skipped_for_newer', 'dropped: invalid_keyframe',
                  'dropped: backend_error', 'dropped: processing_error']


class SaturatedInput(unittest.TestCase):
    def test_every_message_of_the_bag_is_accounted_for(self):
        bag_counts = collections.Counter()
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            for topic, _, _ in bag.read_messages():
                bag_counts[topic] += 1
        watch = NodeWatch(rospy.get_param('~node'))
        timeout = float(rospy.get_param('~timeout', 240))
        done = watch.wait_for(lambda: watch.message.startswith('input ended, idle') and
                              watch.count('queued') == 0, timeout)
        d = watch.diagnostics
        self.assertTrue(done, 'the nodelet did not end idle within %.0f s: %s %s' % (timeout, watch.message, d))
        rospy.loginfo('check_saturated_input: load average %s; %s', os.getloadavg(), d)

        received = {k[len('received on '):]: watch.count(k) for k in d if k.startswith('received on ')}
        lost = {k[len('lost on '):]: watch.count(k) for k in d if k.startswith('lost on ')}
        self.assertEqual(sorted(received), sorted(lost), d)
        self.assertEqual(len(received), 3, received)  # image, camera_info, pose
        for topic in received:
            self.assertEqual(received[topic] + lost[topic], bag_counts[topic],
                             '%s: %d received + %d lost, the bag holds %d' % (
                                 topic, received[topic], lost[topic], bag_counts[topic]))
        self.assertEqual(sum(lost.values()), watch.count('dropped: before_subscriber'), d)

        image_topic = [t for t in received if t.endswith('image_raw')][0]
        self.assertEqual(watch.count('frames_received') + watch.count('images_not_synchronised'),
                         received[image_topic], d)
        outcomes = {k: watch.count(k) for k in FRAME_OUTCOMES}
        self.assertEqual(sum(outcomes.values()), watch.count('frames_received'), outcomes)
        self.assertEqual(watch.count('keyframes_received'), watch.count('keyframes_sent'), d)
        first_depth_maps = watch.count('depth_maps') - watch.count('late_depth_maps')
        fates = first_depth_maps + watch.count('keyframes_without_sources') + \
            sum(watch.count(k) for k in PIPELINE_DROPS)
        self.assertEqual(fates, watch.count('keyframes_received'), d)
        self.assertGreater(first_depth_maps, 0, d)
        rospy.loginfo('check_saturated_input: the bag %s; received %s, lost %s; frames %s; %d keyframes: '
                      '%d first depth maps, %d without sources, drops %s', dict(bag_counts), received, lost,
                      outcomes, watch.count('keyframes_received'), first_depth_maps,
                      watch.count('keyframes_without_sources'), {k: watch.count(k) for k in PIPELINE_DROPS})


if __name__ == '__main__':
    rospy.init_node('check_saturated_input')
    rostest.rosrun('amhmvs_mapping', 'saturated_input', SaturatedInput, sys.argv)
