#!/usr/bin/env python3
"""rostest checker of the mapping nodelet's outputs on a replayed bag.

Records the input image stamps and poses and every output (depth/image,
depth/camera_info, confidence/image, depth/preview, keyframe_cloud, map,
/diagnostics), waits until all frames were played and every keyframe with
source views has its depth and the nodelet is idle (or the timeout), then
checks them. Every frame of the fountain bag is a keyframe (~1.5 m between
frames), and every keyframe gets a depth image: the first has no source view
when it arrives and gets its depth map late, once the second is there. With ~sparse_points set, the depth images
and the global map are checked against those points (sparse_agreement.py).
"""
import math
import os
import struct
import sys
import threading
import time
import unittest

import rosnode
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
import sensor_msgs.point_cloud2 as pc2

from amhmvs_mapping.msg import Keyframe

import sparse_agreement


class Recorder:
    def __init__(self, ns, image_topic, pose_topic, keyframe_topic=''):
        self.lock = threading.Lock()
        self.images, self.depth, self.info, self.confidence, self.preview, self.clouds = [], [], [], [], [], []
        self.diagnostics = {}
        self.poses, self.maps = {}, []
        subs = [(image_topic, Image, self.images), (ns + '/depth/image', Image, self.depth),
                (ns + '/depth/camera_info', CameraInfo, self.info),
                (ns + '/confidence/image', Image, self.confidence),
                (ns + '/depth/preview', Image, self.preview), (ns + '/keyframe_cloud', PointCloud2, self.clouds)]
        self.subscribers = [rospy.Subscriber(t, cls, self._append, callback_args=store, queue_size=50,
                                             buff_size=1 << 24) for t, cls, store in subs]
        self.subscribers.append(rospy.Subscriber('/diagnostics', DiagnosticArray, self._diagnostics))
        self.subscribers.append(rospy.Subscriber(pose_topic, PoseStamped, self._pose, queue_size=50))
        if keyframe_topic:  # keyframe input: the images and poses come in the keyframes
            self.subscribers.append(rospy.Subscriber(keyframe_topic, Keyframe, self._keyframe, queue_size=50,
                                                     buff_size=1 << 24))
        self.subscribers.append(rospy.Subscriber(ns + '/map', PointCloud2, self._append, callback_args=self.maps,
                                                 queue_size=5, buff_size=1 << 26))

    def _pose(self, msg):
        with self.lock:
            self.poses[msg.header.stamp] = msg.pose

    def _keyframe(self, msg):
        with self.lock:
            self.images.append(msg.image)
            self.poses[msg.header.stamp] = msg.camera_to_world

    def _append(self, msg, store):
        with self.lock:
            store.append(msg)

    def _diagnostics(self, msg):
        for status in msg.status:
            if 'depth estimation' in status.name:
                with self.lock:
                    self.diagnostics = {kv.key: kv.value for kv in status.values}


def floats(msg):
    return struct.unpack('<%df' % (msg.width * msg.height), bytes(msg.data))


class ReplayOutputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('check_outputs')
        cls.ns = rospy.get_param('~namespace', '/amhmvs')
        cls.expected_frames = rospy.get_param('~expected_frames', 11)
        cls.optical_frame = rospy.get_param('~optical_frame', 'camera_optical')
        cls.min_depth = rospy.get_param('~min_depth', 4.0)
        cls.max_depth = rospy.get_param('~max_depth', 20.0)
        cls.max_image_size = rospy.get_param('~max_image_size', 256)
        cls.min_cloud_points = rospy.get_param('~min_cloud_points', 1000)
        timeout = rospy.get_param('~timeout', 240.0)
        cls.sparse_points_path = rospy.get_param('~sparse_points', '')
        cls.depth_floors = rospy.get_param('~depth_floors', [0.0, 0.0, 0.0])
        cls.map_floors = rospy.get_param('~map_floors', [0.0, 0.0, 0.0])
        cls.min_map_coverage = rospy.get_param('~min_map_coverage', 0.0)
        # ~confidence/enabled (default): a depth image is published when its
        # keyframe is fused, NaN where the confidence is below the level;
        # otherwise when estimated, every estimate.
        cls.published_when_fused = rospy.get_param(cls.ns + '/mapping/confidence/enabled', True)
        # Each depth image's finite share (as estimated), or with the mask the
        # pooled share of the keyframes' latest images.
        cls.min_finite_fraction = rospy.get_param('~min_finite_fraction', 0.8)
        cls.min_depth_coverage = rospy.get_param('~min_depth_coverage', 0.0)  # published share of the observations
        rec = Recorder(cls.ns, rospy.get_param('~image_topic', '/camera/image_raw'),
                       rospy.get_param('~pose_topic', '/camera/pose'), rospy.get_param('~keyframe_topic', ''))
        start = time.time()  # wall clock: simulated time stops with the bag
        expected_depth = cls.expected_frames
        while time.time() - start < timeout:
            with rec.lock:
                # keyframe_cloud comes when a keyframe is fused, i.e. once
                # min_consistent_views other depth maps can check it; the
                # last ones may still wait for fusion.
                done = (len(rec.images) >= cls.expected_frames and len(rec.depth) >= expected_depth
                        and len(rec.info) >= expected_depth
                        and rec.diagnostics.get('depth_maps') == str(expected_depth)
                        and rec.diagnostics.get('idle') == 'True'
                        and len(rec.clouds) >= int(rec.diagnostics.get('keyframes_fused', '0')))
            if done:
                break
            time.sleep(0.5)
        # The map after the last keyframe: latched and republished each ~map_publish_period.
        map_deadline = time.time() + 10
        while time.time() < map_deadline:
            with rec.lock:
                if rec.maps and rec.maps[-1].header.stamp >= max(m.header.stamp for m in rec.depth or rec.images):
                    break
            time.sleep(0.2)
        time.sleep(3.0)  # late messages and one more diagnostics update
        cls.rec = rec
        cls.elapsed = time.time() - start
        rospy.loginfo('check_outputs: %d images, %d depth, %d info, %d confidence, %d preview, %d clouds in %.0f s; '
                      'diagnostics %s', len(rec.images), len(rec.depth), len(rec.info), len(rec.confidence),
                      len(rec.preview), len(rec.clouds), cls.elapsed, rec.diagnostics)

    def test_01_all_frames_played(self):
        self.assertEqual(len(self.rec.images), self.expected_frames)

    def latest_depth(self):
        """stamp -> the last depth image of that keyframe (a refined depth map
        comes again with the keyframe's stamp)."""
        return {m.header.stamp: m for m in self.rec.depth}

    def test_02_depth_for_every_keyframe(self):
        image_stamps = sorted(m.header.stamp for m in self.rec.images)
        depth_stamps = [m.header.stamp for m in self.rec.depth]
        # Every frame is a keyframe, each depth image has its stamp; the
        # first keyframe's comes late (after the second's). Refined depth
        # maps come again, once per keyframe at most (max_refinements 1).
        # Published when fused: in fusion order, again when a refined one is
        # fused again, and again when more consistency views see a keyframe
        # fused with fewer than 4 (the first ones: 2 -> 3 -> 4 views).
        self.assertEqual(sorted(set(depth_stamps)), image_stamps)
        if not self.published_when_fused:
            self.assertEqual(depth_stamps[:2], [image_stamps[1], image_stamps[0]])
        most = 4 if self.published_when_fused else 2
        self.assertTrue(all(depth_stamps.count(s) <= most for s in image_stamps),
                        'depth images per keyframe: %s' % [depth_stamps.count(s) for s in image_stamps])
        again = 'keyframes_fused_again' if self.published_when_fused else 'refined_depth_maps'
        self.assertEqual(len(depth_stamps) - len(image_stamps), int(self.rec.diagnostics.get(again, '0')))

    def test_03_depth_format(self):
        self.assertTrue(self.rec.depth)
        for msg in self.rec.depth:
            self.assertEqual(msg.encoding, '32FC1')
            self.assertEqual(msg.header.frame_id, self.optical_frame)
            self.assertEqual(max(msg.width, msg.height), self.max_image_size)
            self.assertEqual(msg.step, 4 * msg.width)
            self.assertEqual(len(msg.data), msg.step * msg.height)

    def test_04_camera_info_matches_depth(self):
        infos = {m.header.stamp: m for m in self.rec.info}
        image = self.rec.images[0]
        for depth in self.rec.depth:
            self.assertIn(depth.header.stamp, infos)
            info = infos[depth.header.stamp]
            self.assertEqual((info.width, info.height), (depth.width, depth.height))
            self.assertEqual(info.header.frame_id, depth.header.frame_id)
            scale = depth.width / image.width
            self.assertAlmostEqual(info.K[0], 689.87 * scale, delta=1e-3 * 689.87)

    def test_05_depth_values(self):
        # Published when fused: each keyframe's latest image (the first one
        # of an early keyframe, fused against 2 views only, may be all NaN).
        messages = list(self.latest_depth().values()) if self.published_when_fused else self.rec.depth
        fractions = [round(100.0 * sum(1 for v in floats(m) if math.isfinite(v)) / (m.width * m.height), 1)
                     for m in messages]
        rospy.loginfo('check_outputs: finite %% of the depth images checked: %s', fractions)
        if self.published_when_fused:
            self.assertGreater(sum(fractions) / len(fractions), 100 * self.min_finite_fraction)
        for msg in messages:
            values = floats(msg)
            finite = [v for v in values if math.isfinite(v)]
            fraction = len(finite) / len(values)
            if self.published_when_fused and not finite:
                continue  # all masked (checked against 2 views only: at most 0.90 in the table)
            if not self.published_when_fused:
                self.assertGreater(fraction, self.min_finite_fraction,
                                   'stamp %s: %.0f %% finite' % (msg.header.stamp, 100 * fraction))
            inside = sum(1 for v in finite if self.min_depth <= v <= self.max_depth) / len(finite)
            self.assertGreater(inside, 0.99)
            median = sorted(finite)[len(finite) // 2]
            self.assertTrue(5.0 <= median <= 18.5, 'median depth %.2f m outside the fountain range' % median)

    def test_06_confidence_and_preview(self):
        self.assertEqual(len(self.rec.confidence), len(self.rec.depth))
        for msg in self.rec.confidence:
            self.assertEqual(msg.encoding, '32FC1')
            values = floats(msg)
            self.assertTrue(all(0.0 <= v <= 1.0 for v in values))
        # A preview of every depth image that has a finite pixel.
        self.assertEqual(len(self.rec.preview),
                         sum(1 for m in self.rec.depth if any(math.isfinite(v) for v in floats(m))))
        for msg in self.rec.preview:
            self.assertEqual(msg.encoding, 'bgr8')
            self.assertEqual(len(msg.data), 3 * msg.width * msg.height)

    def test_07_keyframe_clouds(self):
        # One cloud per fused keyframe (published when it is fused), with that
        # keyframe's depth stamp; the others wait for fusion.
        # A refined keyframe is fused (and its cloud published) again.
        diag = self.rec.diagnostics
        depth_stamps = set(m.header.stamp for m in self.rec.depth)
        cloud_stamps = [m.header.stamp for m in self.rec.clouds]
        fused, again = int(diag.get('keyframes_fused', '-1')), int(diag.get('keyframes_fused_again', '0'))
        self.assertEqual(len(set(cloud_stamps)), fused)
        self.assertEqual(len(cloud_stamps), fused + again)
        waiting = 0 if self.published_when_fused else int(diag.get('keyframes_waiting_for_fusion', '-1'))
        self.assertEqual(fused + waiting, len(depth_stamps))
        self.assertTrue(set(cloud_stamps) <= depth_stamps)
        self.assertGreater(len(cloud_stamps), 0)
        # Each keyframe's current cloud (the last: a refined keyframe's
        # replaces its first) has a plausible size.
        latest = {m.header.stamp: m for m in self.rec.clouds}
        for msg in latest.values():
            self.assertGreater(msg.width * msg.height, self.min_cloud_points)
        for msg in self.rec.clouds:
            self.assertEqual(msg.header.frame_id, self.optical_frame)
            names = [f.name for f in msg.fields]
            self.assertEqual(names, ['x', 'y', 'z', 'rgb', 'normal_x', 'normal_y', 'normal_z'])
            points = list(pc2.read_points(msg, field_names=names))
            self.assertEqual(len(points), msg.width * msg.height)
            for p in points:
                self.assertTrue(all(math.isfinite(v) for v in p))
            zs = sorted(p[2] for p in points)
            self.assertTrue(self.min_depth <= zs[len(zs) // 2] <= self.max_depth)

    def test_08_diagnostics_counts(self):
        diag = self.rec.diagnostics
        self.assertTrue(diag, 'no diagnostics received')
        self.assertEqual(diag.get('keyframes_received'), str(self.expected_frames))
        self.assertEqual(diag.get('keyframes_without_sources'), '1')  # the first keyframe, on arrival
        self.assertEqual(diag.get('late_depth_maps'), '1')  # ... and its depth map after the second
        self.assertEqual(diag.get('keyframes_waiting_for_sources'), '0')
        self.assertEqual(diag.get('depth_maps'), str(self.expected_frames))  # first estimates; refinements apart
        # Every drop reason is listed (typed counters), each at 0.
        self.assertIn('dropped: queue_full', diag)
        self.assertEqual({k: v for k, v in diag.items() if k.startswith('dropped') and v != '0'}, {})
        self.assertGreater(int(diag.get('map voxels', '0')), 0)
        # Every message that reached a subscriber is counted, and every image
        # became a frame (none left in the synchroniser or dropped unseen).
        received = {k[len('received on '):]: int(v) for k, v in diag.items() if k.startswith('received on ')}
        self.assertTrue(received, diag)
        for topic, count in received.items():
            self.assertEqual(count, self.expected_frames, (topic, received))
        self.assertEqual(diag.get('images_not_synchronised'), '0')

    def cameras(self):
        """view id (order of the image stamps) -> Camera of each depth image."""
        stamps = sorted(m.header.stamp for m in self.rec.images)
        infos = {m.header.stamp: m for m in self.rec.info}
        return {stamps.index(d.header.stamp): (d, sparse_agreement.Camera(infos[d.header.stamp],
                                                                          self.rec.poses[d.header.stamp]))
                for d in self.latest_depth().values()}

    def agreement(self, depth_at_of_view):
        """Pooled (observations, finite, [within 1 / 2 / 5 %]) over the depth
        images' views; depth_at_of_view(depth msg, camera) -> depth_at(u, v)."""
        sparse = sparse_agreement.read_sparse_points(self.sparse_points_path)
        total, finite, within = 0, 0, [0, 0, 0]
        for view, (depth, camera) in self.cameras().items():
            n, f, w = sparse_agreement.agreement(depth_at_of_view(depth, camera), camera, view, sparse)
            total, finite = total + n, finite + f
            within = [a + b for a, b in zip(within, w)]
        return total, finite, within

    def test_09_depth_agrees_with_sparse_points(self):
        if not self.sparse_points_path:
            self.skipTest('no ~sparse_points')

        def depth_at(depth, _):
            values = floats(depth)
            return lambda u, v: values[v * depth.width + u]
        total, finite, within = self.agreement(depth_at)
        # Masked: accuracy over the published observations, and their share.
        checked = finite if self.published_when_fused else total
        percent = [100.0 * w / max(checked, 1) for w in within]
        coverage = 100.0 * finite / total
        rospy.loginfo('check_outputs: depth images vs sparse points: %.1f / %.1f / %.1f %% within 1 / 2 / 5 %% '
                      'over %d of %d observations (%.1f %% with depth)', percent[0], percent[1], percent[2], checked,
                      total, coverage)
        self.assertGreater(total, 1000)
        for p, floor in zip(percent, self.depth_floors):
            self.assertGreaterEqual(p, floor)
        self.assertGreaterEqual(coverage, self.min_depth_coverage)

    def test_10_global_map(self):
        self.assertTrue(self.rec.maps, 'no map received')
        msg = self.rec.maps[-1]
        self.assertEqual(msg.header.frame_id, 'world')
        names = [f.name for f in msg.fields]
        self.assertEqual(names, ['x', 'y', 'z', 'rgb', 'normal_x', 'normal_y', 'normal_z'])
        points = list(pc2.read_points(msg, field_names=names))
        self.assertGreater(len(points), 1000)
        for p in points:
            self.assertTrue(all(math.isfinite(v) for v in p))
        if not self.sparse_points_path:
            return
        # The map rendered into each keyframe's camera (1 px splats): its
        # accuracy where it covers a sparse point, and how many it covers.
        positions = [p[:3] for p in points]

        def rendered(_, camera):
            zbuffer = sparse_agreement.render_depth(positions, camera)
            return lambda u, v: zbuffer.get((u, v), math.nan)
        total, covered, within = self.agreement(rendered)
        percent = [100.0 * w / max(covered, 1) for w in within]
        coverage = 100.0 * covered / total
        rospy.loginfo('check_outputs: map (%d points) vs sparse points: %.1f / %.1f / %.1f %% within 1 / 2 / 5 %% '
                      'of the %d covered observations (%.1f %% of %d)', len(points), percent[0], percent[1],
                      percent[2], covered, coverage, total)
        for p, floor in zip(percent, self.map_floors):
            self.assertGreaterEqual(p, floor)
        self.assertGreaterEqual(coverage, self.min_map_coverage)

    def test_11_map_saved_on_shutdown(self):
        """~save_map_on_shutdown: the process that holds the nodelet (the
        standalone node or the manager), asked to shut down as roslaunch's
        Ctrl-C does, writes the map it last published and exits."""
        path = rospy.get_param('~shutdown_map', '')
        if not path:
            return
        node = rospy.get_param('~node', self.ns + '/mapping')
        self.assertFalse(os.path.exists(path), path)
        self.assertEqual(rosnode.kill_nodes([node])[1], [], 'could not ask ' + node + ' to shut down')
        # Bounds, not guesses: the worker ends after the step it is in, then
        # the map is saved (renamed into place whole) and the process exits.
        count = ply_count(path, 'element vertex', 60, 'no map at ' + path + ' within 60 s of the shutdown')
        rospy.loginfo('check_outputs: %s written at shutdown by %s, %d points', path, node, count)
        self.assertEqual(count, self.rec.maps[-1].width)
        params = self.ns + '/mapping'  # the nodelet's, also when `node` is its manager
        if rospy.get_param(params + '/surface/enabled', True) and rospy.get_param(params + '/confidence/enabled', True):
            # The surface mesh beside it, written after the map.
            mesh_path = os.path.splitext(path)[0] + '_mesh.ply'
            faces = ply_count(mesh_path, 'element face', 30, 'no mesh at ' + mesh_path + ' after the map')
            rospy.loginfo('check_outputs: %s written at shutdown, %d triangles', mesh_path, faces)
            self.assertGreater(faces, 0)
        deadline = time.time() + 20
        while time.time() < deadline and rosnode.rosnode_ping(node, max_count=1):
            time.sleep(0.5)
        self.assertFalse(rosnode.rosnode_ping(node, max_count=1), node + ' still answers 20 s after its map was saved')

def ply_count(path, line_start, seconds, missing):
    """The count on a PLY header's line (e.g. 'element vertex N') once the
    file is there (renamed into place whole), waiting at most `seconds`."""
    deadline = time.time() + seconds
    while time.time() < deadline and not os.path.exists(path):
        time.sleep(0.2)
    if not os.path.exists(path):
        raise AssertionError(missing)
    with open(path, 'rb') as f:
        header = f.read(2000).decode('ascii', 'replace')
    return int([l for l in header.splitlines() if l.startswith(line_start)][0].split()[-1])


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'replay_fountain', ReplayOutputs, sys.argv)
