#!/usr/bin/env python3
"""rostest checker: keyframe-message mode driven by a small publisher (the
fountain frames as amhmvs_mapping/Keyframe with their sparse points; the first,
without a source view on arrival, gets its depth map late), the map export
(none before a subscriber comes, a current map when one does), then the
services and loop closure: ~save_map to PLY and PCD (and a refused
extension), a KeyframePoses update that moves every keyframe 1 m along x
(the map must follow), a runtime voxel-size change (dynamic_reconfigure),
~pause / ~resume, and ~reset (empty map)."""
import copy
import os
import sys
import tempfile
import unittest

import dynamic_reconfigure.client
import rospy
import rostest
from sensor_msgs.msg import Image, PointCloud2
import sensor_msgs.point_cloud2 as pc2

from amhmvs_mapping.msg import Keyframe, KeyframePose, KeyframePoses
from amhmvs_mapping.srv import SaveMap
import fountain_keyframes
from node_watch import NodeWatch
import sparse_agreement

KEYFRAMES = 4
SHIFT_X = 1.0  # metres, the loop-closure correction


def centroid(msg):
    points = list(pc2.read_points(msg, field_names=('x', 'y', 'z')))
    return [sum(p[i] for p in points) / len(points) for i in range(3)], len(points)


class KeyframeServices(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('check_keyframe_services')
        ns = rospy.get_param('~namespace', '/amhmvs')
        cls.ns = ns
        cls.watch = NodeWatch(rospy.get_param('~node', '/amhmvs/mapping'))
        cls.depth = cls.watch.record(ns + '/depth/image', Image)
        cls.maps = []  # subscribed later
        cls.pub = rospy.Publisher('/keyframe', Keyframe, queue_size=20)
        cls.poses_pub = rospy.Publisher(ns + '/keyframe_poses', KeyframePoses, queue_size=5)
        cls.frames = fountain_keyframes.read_frames(rospy.get_param('~bag'))
        cls.sparse = sparse_agreement.read_sparse_points(rospy.get_param('~sparse_points'))
        cls.watch.wait_for(lambda: cls.pub.get_num_connections() > 0 and cls.poses_pub.get_num_connections() > 0,
                           30)

    def keyframe(self, index, keyframe_id):
        return fountain_keyframes.keyframe_msg(self.frames[index], index, keyframe_id,
                                               rospy.Time.from_sec(1000.0 + keyframe_id), self.sparse)

    def latest_map(self):
        with self.watch.lock:
            return self.maps[-1] if self.maps else None

    def test_services_and_loop_closure(self):
        watch = self.watch
        for i in range(KEYFRAMES):
            self.pub.publish(self.keyframe(i, i))
        # A depth map for every keyframe: keyframe 0 (no source on arrival) late.
        self.assertTrue(watch.wait_for(lambda: watch.count('depth_maps') == KEYFRAMES, 120), watch.diagnostics)
        self.assertEqual(watch.count('keyframes_without_sources'), 1)
        self.assertEqual(watch.count('late_depth_maps'), 1)
        self.assertEqual(watch.count('keyframes_waiting_for_sources'), 0)
        # Each with its keyframe's stamp; refined depth maps come again.
        self.assertTrue(watch.wait_for(lambda: watch.diagnostics.get('idle') == 'True', 60), watch.diagnostics)
        self.assertEqual(len(self.depth), KEYFRAMES + watch.count('refined_depth_maps'))
        self.assertEqual(sorted(set(m.header.stamp.to_sec() for m in self.depth)),
                         [1000.0 + i for i in range(KEYFRAMES)])

        # Nobody subscribes to ~map yet: the map exists but is never exported.
        self.assertTrue(watch.wait_for(lambda: watch.count('map voxels') > 0 and watch.count('queued') == 0, 30),
                        watch.diagnostics)
        self.assertEqual(watch.count('map_publications'), 0, watch.diagnostics)
        voxels = watch.count('map voxels')
        # A subscriber comes: a current map at once (no waiting for the rate).
        self.__class__.maps = watch.record(self.ns + '/map', PointCloud2)
        self.assertTrue(watch.wait_for(lambda: self.maps and self.maps[-1].width == voxels, 5),
                        ([m.width for m in self.maps], voxels, watch.diagnostics))
        # Map floor: measured MEASURE_ME points with deferred fusion (every point
        # confirmed by 2 other depth maps; 128 px, 2 iterations).
        self.assertGreater(voxels, 310)
        before, count_before = centroid(self.latest_map())

        # Save: PLY and PCD by extension, the point count in the header.
        folder = tempfile.mkdtemp()
        for name, count_line in (('map.ply', 'element vertex'), ('map.pcd', 'POINTS')):
            path = os.path.join(folder, name)
            res = watch.call('save_map', SaveMap, path)
            self.assertTrue(res.success, res.message)
            with open(path, 'rb') as f:
                header = f.read(2000).decode('ascii', 'replace')
            line = [l for l in header.splitlines() if l.startswith(count_line)][0]
            self.assertEqual(int(line.split()[-1]), count_before, line)
        res = watch.call('save_map', SaveMap, os.path.join(folder, 'map.txt'))
        self.assertFalse(res.success)
        self.assertIn('map.txt', res.message)
        res = watch.call('save_map', SaveMap, '')
        self.assertFalse(res.success)
        self.assertIn('empty path', res.message)
        # A relative path lands in ~map_directory (here its default: where
        # roslaunch started, $PWD, not the node's ~/.ros), named in full.
        relative = 'amhmvs_keyframe_services_map.ply'
        expected = os.path.join(os.environ['PWD'], relative)
        try:
            res = watch.call('save_map', SaveMap, relative)
            self.assertTrue(res.success, res.message)
            self.assertTrue(res.message.endswith(' to ' + expected), res.message)
            self.assertTrue(os.path.isfile(expected))
        finally:
            if os.path.exists(expected):
                os.remove(expected)

        # Loop closure: every keyframe 1 m along x; the map follows.
        update = KeyframePoses()
        update.header.frame_id = 'world'
        for i in range(KEYFRAMES):
            entry = KeyframePose(keyframe_id=i, camera_to_world=copy.deepcopy(self.frames[i]['pose'].pose))
            entry.camera_to_world.position.x += SHIFT_X
            update.poses.append(entry)
        maps_before = len(self.maps)
        self.poses_pub.publish(update)
        self.assertTrue(watch.wait_for(lambda: watch.count('pose_updates_applied') == KEYFRAMES, 10),
                        watch.diagnostics)
        self.assertTrue(watch.wait_for(lambda: len(self.maps) > maps_before and
                                       abs(centroid(self.maps[-1])[0][0] - before[0] - SHIFT_X) < 0.1, 10))
        after, count_after = centroid(self.latest_map())
        rospy.loginfo('check_keyframe_services: map of %d points moved by %s (%d points after)', count_before,
                      [a - b for a, b in zip(after, before)], count_after)
        leaf = rospy.get_param('~voxel_size')
        self.assertAlmostEqual(after[0] - before[0], SHIFT_X, delta=leaf)
        self.assertAlmostEqual(after[1] - before[1], 0.0, delta=leaf)
        self.assertAlmostEqual(after[2] - before[2], 0.0, delta=leaf)
        self.assertAlmostEqual(count_after, count_before, delta=0.05 * count_before)  # re-voxelised

        # dynamic_reconfigure: a coarser voxel size rebuilds the map at once.
        reconfigured = watch.count('reconfigurations')
        maps_before = len(self.maps)
        client = dynamic_reconfigure.client.Client(watch.node, timeout=10)
        self.assertAlmostEqual(client.get_configuration(timeout=10)['voxel_size'], leaf)  # from the yaml
        client.update_configuration({'voxel_size': 4 * leaf})
        self.assertTrue(watch.wait_for(lambda: watch.count('reconfigurations') == reconfigured + 1, 10),
                        watch.diagnostics)
        self.assertTrue(watch.wait_for(lambda: len(self.maps) > maps_before, 10))
        coarse = self.latest_map().width
        rospy.loginfo('check_keyframe_services: voxel size %.2f -> %.2f m: %d -> %d map points', leaf, 4 * leaf,
                      count_after, coarse)
        self.assertGreater(coarse, 0)
        self.assertLess(coarse, count_after)  # measured 1226 -> 718: coarser voxels merge points

        # ... and min_points_per_voxel republishes it without the thin voxels,
        # then with all of them again.
        for min_points, expect in ((1000, lambda width: width < coarse), (1, lambda width: width == coarse)):
            reconfigured = watch.count('reconfigurations')
            maps_before = len(self.maps)
            client.update_configuration({'min_points_per_voxel': min_points})
            self.assertTrue(watch.wait_for(lambda: watch.count('reconfigurations') == reconfigured + 1, 10),
                            watch.diagnostics)
            self.assertTrue(watch.wait_for(lambda: len(self.maps) > maps_before, 10))
            rospy.loginfo('check_keyframe_services: min_points_per_voxel %d: %d map points', min_points,
                          self.latest_map().width)
            self.assertTrue(expect(self.latest_map().width), self.latest_map().width)

        # Pause: input ignored and counted; resume; reset: an empty map.
        self.assertTrue(watch.call('pause').success)
        self.pub.publish(self.keyframe(KEYFRAMES, KEYFRAMES))
        self.assertTrue(watch.wait_for(lambda: watch.count('ignored_while_paused') == 1, 10), watch.diagnostics)
        self.assertTrue(watch.call('resume').success)
        self.assertTrue(watch.call('reset').success)
        # Diagnostics show the reset at once: work and state counters restart
        # (drop counters are lifetime).
        self.assertTrue(watch.wait_for(lambda: watch.count('depth_maps') == 0 and watch.count('stored_keyframes') == 0
                                       and watch.count('keyframes_received') == 0, 5), watch.diagnostics)
        self.pub.publish(self.keyframe(KEYFRAMES, KEYFRAMES + 1))  # the reset takes effect before it
        self.assertTrue(watch.wait_for(lambda: watch.count('keyframes_without_sources') == 1 and
                                       watch.count('stored_keyframes') == 1, 30), watch.diagnostics)
        self.assertTrue(watch.wait_for(lambda: self.maps[-1].width == 0, 10))


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'keyframe_services', KeyframeServices, sys.argv)
