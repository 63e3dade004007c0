#!/usr/bin/env python3
"""rostest checker: a hostile stream in pose mode, in simulated time that the
checker drives (/clock). Good fountain frames, then stretches whose image
encoding changes, whose camera_info turns bad (NaN, a size that does not fit
the image), whose image size and aspect change (a valid camera: mapped),
whose poses turn NaN, then the clock jumps back (a bag played again) and the
stream goes on from the earlier time, and one stamp goes back while the clock
does not. The nodelet keeps mapping after each bad stretch: the frames after
the jump get depth images, every drop is counted under its reason, and the
counters add up to what was published."""
import copy
import math
import sys
import unittest

import numpy as np
import rosbag
import rospy
import rostest
from rosgraph_msgs.msg import Clock
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, Image

from node_watch import NodeWatch

# Keys whose sum with keyframes_sent is every frame received (pose mode: a
# frame is an image, its camera_info and its pose with one stamp).
FRAME_OUTCOMES = ['keyframes_sent', 'frames_not_keyframes', 'frames_refused_pure_rotation',
                  'frames_refused_blurred', 'ignored_while_paused', 'dropped: encoding', 'dropped: bad_pose',
                  'dropped: bad_camera_info', 'dropped: bad_keyframe', 'dropped: stamp_backwards',
                  'dropped: bad_stamp']


def cropped(image, info, size):
    """The frame's centre, size x size: another camera (size and aspect)."""
    image, info = copy.deepcopy(image), copy.deepcopy(info)
    pixels = np.frombuffer(image.data, np.uint8).reshape(image.height, image.width, 3)
    top, left = (image.height - size) // 2, (image.width - size) // 2
    image.data = pixels[top:top + size, left:left + size].tobytes()
    image.width = image.height = info.width = info.height = size
    image.step = 3 * size
    k = list(info.K)
    k[2] -= left
    k[5] -= top
    info.K = k
    p = list(info.P)
    if len(p) == 12:
        p[2] -= left
        p[6] -= top
        info.P = p
    return image, info


class HostileStream(unittest.TestCase):
    def test_mapping_goes_on_after_each_bad_stretch(self):
        rospy.init_node('check_hostile_stream')
        watch = NodeWatch(rospy.get_param('~node', '/amhmvs/mapping'))
        depth = watch.record('/amhmvs/depth/image', Image)
        clock_pub = rospy.Publisher('/clock', Clock, queue_size=10)
        image_pub = rospy.Publisher('/camera/image_raw', Image, queue_size=10)
        info_pub = rospy.Publisher('/camera/camera_info', CameraInfo, queue_size=10)
        pose_pub = rospy.Publisher('/camera/pose', PoseStamped, queue_size=10)
        frames = {}
        with rosbag.Bag(rospy.get_param('~bag')) as bag:
            for topic, msg, _ in bag.read_messages(['/camera/image_raw', '/camera/camera_info', '/camera/pose']):
                frames.setdefault(topic, []).append(msg)
        images, infos, poses = frames['/camera/image_raw'], frames['/camera/camera_info'], frames['/camera/pose']

        def set_clock(seconds):
            clock_pub.publish(Clock(clock=rospy.Time.from_sec(seconds)))

        set_clock(1000.0)
        self.assertTrue(watch.wait_for(lambda: all(p.get_num_connections() > 0 for p in
                                                   (image_pub, info_pub, pose_pub)) and watch.diagnostics, 30))
        published = [0]

        def publish(index, stamp, image=None, info=None, pose=None):
            """One frame (fountain view `index` unless given), its three
            messages at `stamp`; returns once the nodelet counted it."""
            image = copy.deepcopy(image or images[index])
            info = copy.deepcopy(info or infos[index])
            pose = copy.deepcopy(pose or poses[index])
            image.header.stamp = info.header.stamp = pose.header.stamp = rospy.Time.from_sec(stamp)
            info_pub.publish(info)
            pose_pub.publish(pose)
            image_pub.publish(image)
            published[0] += 1
            self.assertTrue(watch.wait_for(lambda: watch.count('frames_received') == published[0], 30),
                            'frame %d (view %d at %.1f s) not counted: %s' % (published[0], index, stamp,
                                                                             watch.diagnostics))

        t = 1000.0
        for index in range(4):                                  # good
            t += 1
            set_clock(t)
            publish(index, t)
        expected = {}

        def expect(reason, n=1):
            expected[reason] = expected.get(reason, 0) + n

        t += 1
        set_clock(t)
        for encoding, channels in (('32FC1', 4), ('yuv422', 2)):  # the encoding changes
            image = copy.deepcopy(images[4])
            image.encoding, image.step = encoding, channels * image.width
            image.data = bytes(image.step * image.height)
            publish(4, t, image=image)
            expect('dropped: encoding')
            t += 0.1
        info = copy.deepcopy(infos[4])                          # camera_info turns bad
        info.K = [math.nan] + list(info.K[1:])
        publish(4, t, info=info)
        t += 0.1
        info = copy.deepcopy(infos[4])
        info.width, info.height = info.width // 2, info.height // 2
        publish(4, t, info=info)
        expect('dropped: bad_camera_info', 2)
        first_cropped = t + 1
        for index in (4, 5):                                    # another size and aspect: mapped
            t += 1
            set_clock(t)
            image, info = cropped(images[index], infos[index], 384)
            publish(index, t, image=image, info=info)
        for index in (6, 7):                                    # poses turn NaN
            t += 1
            set_clock(t)
            pose = copy.deepcopy(poses[index])
            pose.pose.position.x = math.nan
            publish(index, t, pose=pose)
            expect('dropped: bad_pose')
        before_jump = t
        t = 500.0                                               # the clock jumps back
        set_clock(t)
        self.assertTrue(watch.wait_for(lambda: watch.stamp is not None and watch.stamp < before_jump - 1, 30),
                        'the nodelet\'s clock did not follow /clock back')
        after_jump = t + 1
        for index in range(6, 11):                              # the stream goes on from there
            t += 1
            set_clock(t)
            if index == 6:  # the first frame of the new time must not look older than the clock
                self.assertTrue(watch.wait_for(lambda: watch.stamp is not None and watch.stamp >= t, 30))
            publish(index, t)
        expect('clock_jumps_back')
        publish(10, t - 3)                                      # a stamp back, the clock not
        expect('dropped: stamp_backwards')

        # Every frame counted under one outcome; each drop under its reason;
        # every keyframe sent processed, and depth images after the jump.
        def after_jump_depth():
            with_stamps = [m.header.stamp.to_sec() for m in depth]
            return {s for s in with_stamps if after_jump - 0.01 <= s <= after_jump + 4.01}
        self.assertTrue(watch.wait_for(lambda: watch.diagnostics.get('idle') == 'True' and
                                       watch.count('keyframes_received') == watch.count('keyframes_sent') and
                                       len(after_jump_depth()) >= 4 and
                                       all(watch.count(r) == n for r, n in expected.items()), 120),
                        'expected %s and 4 depth images after the jump (%s), diagnostics %s' % (
                            expected, sorted(after_jump_depth()), watch.diagnostics))
        outcomes = {key: watch.count(key) for key in FRAME_OUTCOMES}
        rospy.loginfo('check_hostile_stream: %d frames published; %s', published[0], outcomes)
        self.assertEqual(sum(outcomes.values()), published[0], outcomes)
        self.assertEqual(watch.count('frames_received'), published[0])
        self.assertEqual(watch.count('images_not_synchronised'), 0, watch.diagnostics)
        for reason in ('dropped: bad_keyframe', 'dropped: bad_stamp', 'dropped: queue_full',
                       'dropped: invalid_keyframe', 'dropped: processing_error'):
            self.assertEqual(watch.count(reason), 0, watch.diagnostics)

        # Mapping went on: the cropped camera's frames and the frames after
        # the jump got depth images of their own size.
        with watch.lock:
            stamps = {m.header.stamp.to_sec(): m for m in depth}
        after = [s for s in stamps if after_jump - 0.01 <= s <= after_jump + 4.01]
        self.assertGreaterEqual(len(after), 4, sorted(stamps))
        crops = [stamps[s] for s in stamps if first_cropped - 0.01 <= s <= first_cropped + 1.01]
        self.assertGreaterEqual(len(crops), 1, sorted(stamps))
        for m in crops:
            self.assertEqual(m.width, m.height, 'a cropped frame\'s depth image is %dx%d' % (m.width, m.height))


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'hostile_stream', HostileStream, sys.argv)
