#!/usr/bin/env python3
"""rostest checker: the nodelet's depth outputs work with the ROS ecosystem.
- depth_image_proc/point_cloud_xyz, run on our depth/image + depth/camera_info
  (32FC1, REP-118), gives an organised cloud whose points lie within
  ~max_median_distance (1 cm) of our keyframe_cloud (median over the points:
  each of ours against the depth_image_proc points of the 3x3 pixels around
  its projection) for every keyframe cloud;
- depth_mm/image (~publish_depth_mm) is REP-118's 16UC1: the same depth in
  millimetres (rounded), 0 where the 32FC1 image is NaN, with the same
  camera_info."""
import sys
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import CameraInfo, Image, PointCloud2

from node_watch import NodeWatch


def xyz(cloud):
    """N x 3 float64 of a PointCloud2 with float32 x, y, z fields."""
    offsets = {f.name: f.offset for f in cloud.fields}
    raw = np.frombuffer(bytes(cloud.data), np.uint8).reshape(-1, cloud.point_step)
    return np.stack([raw[:, offsets[n]:offsets[n] + 4].copy().view('<f4')[:, 0] for n in 'xyz'], 1).astype(float)


def image_array(msg):
    dtype = {'32FC1': '<f4', '16UC1': '<u2'}[msg.encoding]
    return np.frombuffer(bytes(msg.data), dtype).reshape(msg.height, msg.width)


def by_stamp(messages):
    """stamp -> the messages of one topic with that stamp, in arrival order
    (a refined depth map comes again with its keyframe's stamp)."""
    groups = {}
    for _, msg in messages:
        groups.setdefault(msg.header.stamp, []).append(msg)
    return groups


def median_distance(ours, theirs, info):
    """Median distance from our points to the nearest depth_image_proc point
    of the 3x3 pixels around their projection, and the share of our points
    that have one."""
    theirs = theirs.reshape(info.height, info.width, 3)
    fx, fy, cx, cy = info.K[0], info.K[4], info.K[2], info.K[5]
    u = np.rint(fx * ours[:, 0] / ours[:, 2] + cx).astype(int)
    v = np.rint(fy * ours[:, 1] / ours[:, 2] + cy).astype(int)
    best = np.full(len(ours), np.inf)
    for dv in (-1, 0, 1):
        for du in (-1, 0, 1):
            uu, vv = np.clip(u + du, 0, info.width - 1), np.clip(v + dv, 0, info.height - 1)
            distance = np.linalg.norm(theirs[vv, uu] - ours, axis=1)
            best = np.fmin(best, np.where(np.isfinite(distance), distance, np.inf))
    compared = np.isfinite(best)
    return (float(np.median(best[compared])) if compared.any() else np.inf), float(compared.mean())


class DepthInterop(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('check_depth_interop')
        ns = rospy.get_param('~namespace', '/amhmvs')
        cls.expected = rospy.get_param('~expected_keyframes')
        cls.max_median = rospy.get_param('~max_median_distance', 0.01)
        watch = NodeWatch(rospy.get_param('~node', '/amhmvs/mapping'))
        cls.arrivals = 0
        cls.recorded = {}

        def record(topic, kind):  # every message with its arrival index (one counter for all)
            cls.recorded[topic] = []

            def append(msg):
                with watch.lock:
                    cls.recorded[topic].append((cls.arrivals, msg))
                    cls.arrivals += 1
            rospy.Subscriber(ns + '/' + topic, kind, append, queue_size=50, buff_size=1 << 27)
        for topic, kind in (('depth/image', Image), ('depth/camera_info', CameraInfo), ('depth/points', PointCloud2),
                            ('keyframe_cloud', PointCloud2), ('depth_mm/image', Image),
                            ('depth_mm/camera_info', CameraInfo)):
            record(topic, kind)

        def processed():
            return watch.count('keyframes_received') >= cls.expected and watch.diagnostics.get('idle') == 'True'
        cls.done = watch.wait_for(processed, rospy.get_param('~timeout', 240.0))
        rospy.sleep(rospy.Duration(0))  # let the last messages in
        watch.wait_for(lambda: len(cls.recorded['depth/points']) >= len(cls.recorded['depth/image']), 20.0)
        cls.diagnostics = watch.diagnostics
        rospy.loginfo('check_depth_interop: %s', ', '.join('%d %s' % (len(m), t) for t, m in cls.recorded.items()))

    def test_01_every_keyframe_processed(self):
        self.assertTrue(self.done, str(self.diagnostics))
        self.assertEqual(len(set(m.header.stamp for _, m in self.recorded['depth/image'])), self.expected)

    def test_02_point_cloud_xyz_matches_our_keyframe_clouds(self):
        clouds = self.recorded['keyframe_cloud']
        self.assertTrue(clouds, 'no keyframe cloud')
        theirs_by_stamp = by_stamp(self.recorded['depth/points'])
        info_by_stamp = by_stamp(self.recorded['depth/camera_info'])
        medians = []
        for _, ours_msg in clouds:
            stamp = ours_msg.header.stamp
            self.assertIn(stamp, theirs_by_stamp, 'no point_cloud_xyz cloud for %s' % stamp)
            ours = xyz(ours_msg)
            # Our cloud was fused from one of the keyframe's depth maps (the
            # first or a refined one): the closest of their clouds.
            candidates = []
            for theirs_msg, info in zip(theirs_by_stamp[stamp], info_by_stamp[stamp]):
                self.assertEqual(theirs_msg.header.frame_id, ours_msg.header.frame_id)
                self.assertEqual((theirs_msg.width, theirs_msg.height), (info.width, info.height))  # organised
                candidates.append(median_distance(ours, xyz(theirs_msg), info))
            median, share = min(candidates)
            self.assertGreater(share, 0.95, 'stamp %s: %.1f %% of our points have a depth_image_proc point '
                               'nearby' % (stamp, 100 * share))
            medians.append(median)
        rospy.loginfo('depth_image_proc vs keyframe_cloud: median distance per cloud %s m',
                      ', '.join('%.4f' % m for m in medians))
        self.assertLess(max(medians), self.max_median, medians)

    def test_03_depth_in_millimetres_is_rep118_16uc1(self):
        mm_by_stamp = by_stamp(self.recorded['depth_mm/image'])
        metres_by_stamp = by_stamp(self.recorded['depth/image'])
        mm_info_by_stamp = by_stamp(self.recorded['depth_mm/camera_info'])
        info_by_stamp = by_stamp(self.recorded['depth/camera_info'])
        self.assertEqual({s: len(m) for s, m in mm_by_stamp.items()}, {s: len(m) for s, m in metres_by_stamp.items()})
        for stamp, mm_msgs in mm_by_stamp.items():
            # Published together: the k-th of each topic is the same depth map.
            for mm_msg, metres_msg, mm_info, info in zip(mm_msgs, metres_by_stamp[stamp], mm_info_by_stamp[stamp],
                                                         info_by_stamp[stamp]):
                self.assertEqual(mm_msg.encoding, '16UC1')
                self.assertEqual(mm_msg.step, 2 * mm_msg.width)
                self.assertEqual(mm_msg.header.frame_id, metres_msg.header.frame_id)
                metres, mm = image_array(metres_msg), image_array(mm_msg).astype(int)
                self.assertEqual(metres.shape, mm.shape)
                valid = np.isfinite(metres)
                self.assertTrue(np.all(mm[~valid] == 0))
                self.assertLessEqual(np.abs(mm[valid] - 1000.0 * metres[valid]).max(), 0.5 + 1e-3)
                self.assertEqual(list(mm_info.K), list(info.K))


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'depth_interop', DepthInterop, sys.argv)
