#!/usr/bin/env python3
"""rostest checker of a replayed bag's keyframes and global map (plumbing and
plausibility, no accuracy): waits until the nodelet received
~expected_keyframes keyframes and is idle (diagnostics), then checks that every depth image has the frame
and stamp of an input image and a matching camera_info, that keyframe clouds
and the map have no NaN point and are in the right frames, that the map is not
empty, and (with ~bbox) that every map point lies in the box widened by
~bbox_margin metres (at most ~max_fraction_elsewhere of the points, default
0, may be elsewhere). With ~truth_topic (32FC1 z-depth images with the input
stamps, e.g. a bag's /camera/depth_gt), each keyframe's last depth image is
compared with the truth of its stamp where both have depth: the pooled median
relative error at most ~max_median_error, at least ~min_within_10pct percent
within 10 %, and at least ~min_truth_within_5pct percent of the truth's valid
pixels (on the depth images' grid) within 5 % (missing = wrong). With ~min_counters (a dict), each named diagnostics counter is
at least its value; with ~max_counters, present and at most its value. With
~truth_dense_dir (an MVSNet dense folder with the true cameras in cams_gt/
and z-depth in depth_gt/, as amhmvs_synthetic writes), the last map is judged against the true surface: at least
~min_map_within_2cm percent of its points (up to ~map_sample points, evenly
spaced) within 2 cm of a point of the back-projected true depth. With
~min_map_within_5cm and ~truth_topic, the last map is judged against the
surface of the truth images themselves (every other pixel of each,
back-projected with the camera_info and the pose topic of its stamp, e.g. the
Kinect depth of a 7-Scenes bag): at least that percent within 5 cm. With
~min_mesh_triangles, the last surface mesh (`mesh`, a TRIANGLE_LIST marker)
has at least that many triangles, no NaN vertex, the map's frame, and with
~min_mesh_within_5cm (and ~truth_topic) at least that percent of its vertices
within 5 cm of the truth images' surface."""
import glob
import math
import os
import struct
import sys
import unittest

import numpy as np

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
import sensor_msgs.point_cloud2 as pc2
from visualization_msgs.msg import Marker

from node_watch import NodeWatch
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from dense_folder_to_bag import quaternion_matrix, read_cam, read_pfm  # noqa: E402  (the writer's own conversions)


class MapReplay(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('check_map')
        ns = rospy.get_param('~namespace', '/amhmvs')
        cls.expected = rospy.get_param('~expected_keyframes')
        cls.optical_frame = rospy.get_param('~optical_frame', 'camera_optical')
        cls.fixed_frame = rospy.get_param('~fixed_frame', 'world')
        cls.bbox = rospy.get_param('~bbox', [])
        cls.margin = rospy.get_param('~bbox_margin', 0.0)
        cls.max_fraction_elsewhere = rospy.get_param('~max_fraction_elsewhere', 0.0)
        cls.min_map_points = rospy.get_param('~min_map_points', 100)
        cls.min_depth_maps = rospy.get_param('~min_depth_maps', 1)
        cls.min_outside_region = rospy.get_param('~min_outside_region', 0)
        node = rospy.get_param('~node', '/amhmvs/mapping')
        # ~confidence/enabled (default): a depth image is published when its
        # keyframe is fused, masked; otherwise when estimated.
        cls.published_when_fused = rospy.get_param(node + '/confidence/enabled', True)
        cls.watch = watch = NodeWatch(node)
        cls.images = watch.record(rospy.get_param('~image_topic', '/camera/image_raw'), Image)
        cls.depth = watch.record(ns + '/depth/image', Image)
        cls.info = watch.record(ns + '/depth/camera_info', CameraInfo)
        cls.clouds = watch.record(ns + '/keyframe_cloud', PointCloud2)
        cls.maps = watch.record(ns + '/map', PointCloud2)
        cls.min_mesh_triangles = rospy.get_param('~min_mesh_triangles', 0)
        cls.min_mesh_within_5cm = rospy.get_param('~min_mesh_within_5cm', 0.0)
        cls.meshes = watch.record(ns + '/mesh', Marker) if cls.min_mesh_triangles > 0 else []
        cls.truth_topic = rospy.get_param('~truth_topic', '')
        cls.truth = watch.record(cls.truth_topic, Image) if cls.truth_topic else []
        cls.max_median_error = rospy.get_param('~max_median_error', 1.0)
        cls.min_within_10pct = rospy.get_param('~min_within_10pct', 0.0)
        cls.min_truth_within_5pct = rospy.get_param('~min_truth_within_5pct', 0.0)
        cls.min_counters = rospy.get_param('~min_counters', {})
        cls.max_counters = rospy.get_param('~max_counters', {})
        cls.truth_dense_dir = rospy.get_param('~truth_dense_dir', '')
        cls.min_map_within_2cm = rospy.get_param('~min_map_within_2cm', 0.0)
        cls.map_sample = rospy.get_param('~map_sample', 5000)
        cls.min_map_within_5cm = rospy.get_param('~min_map_within_5cm', 0.0)
        if cls.min_map_within_5cm > 0 or cls.min_mesh_within_5cm > 0:
            cls.poses = watch.record(rospy.get_param('~pose_topic', '/camera/pose'), PoseStamped)
            cls.camera_infos = watch.record(rospy.get_param('~camera_info_topic', '/camera/camera_info'), CameraInfo)

        def processed():  # idle: every late depth map is out too
            return watch.count('keyframes_received') >= cls.expected and watch.diagnostics.get('idle') == 'True'
        cls.done = watch.wait_for(processed, rospy.get_param('~timeout', 240.0))
        maps_then = len(cls.maps)
        watch.wait_for(lambda: len(cls.maps) > maps_then, 10.0)  # the map after the last keyframe
        cls.diagnostics = watch.diagnostics
        rospy.loginfo('check_map: %d images, %d depth, %d clouds, %d maps; diagnostics %s', len(cls.images),
                      len(cls.depth), len(cls.clouds), len(cls.maps), cls.diagnostics)

    def test_01_all_keyframes_processed_nothing_dropped(self):
        self.assertTrue(self.done, str(self.diagnostics))
        self.assertEqual(int(self.diagnostics.get('keyframes_received', 0)), self.expected)
        self.assertIn('dropped: queue_full', self.diagnostics)  # every drop reason listed, each at 0
        self.assertEqual({k: v for k, v in self.diagnostics.items() if k.startswith('dropped') and v != '0'}, {})
        depth_stamps = set(m.header.stamp for m in self.depth)  # refined depth maps come again
        self.assertGreaterEqual(len(depth_stamps), self.min_depth_maps)
        unpublished = self.watch.count('keyframes_waiting_for_sources')
        if self.published_when_fused:
            unpublished += self.watch.count('keyframes_waiting_for_fusion')
        self.assertEqual(unpublished, self.expected - len(depth_stamps))
        # With a region of interest: it kept points out (they are counted).
        self.assertGreaterEqual(self.watch.count('map_points_outside_region'), self.min_outside_region)

    def test_02_depth_frames_stamps_and_camera_info(self):
        stamps = set(m.header.stamp for m in self.images)
        infos = {m.header.stamp: m for m in self.info}
        for depth in self.depth:
            self.assertEqual(depth.header.frame_id, self.optical_frame)
            self.assertIn(depth.header.stamp, stamps)
            self.assertEqual(depth.encoding, '32FC1')
            info = infos[depth.header.stamp]
            self.assertEqual((info.width, info.height), (depth.width, depth.height))
            self.assertEqual(info.header.frame_id, self.optical_frame)
            self.assertGreater(info.K[0], 0)

    def test_03_clouds_finite_in_their_frames(self):
        # keyframe_cloud: one per fused keyframe, with its depth stamp; the
        # others wait for fusion (too few consistency views).
        # (a refined keyframe is fused and published again).
        fused = int(self.diagnostics.get('keyframes_fused', '-1'))
        again = int(self.diagnostics.get('keyframes_fused_again', '0'))
        waiting = int(self.diagnostics.get('keyframes_waiting_for_fusion', '-1'))
        self.assertEqual(len(self.clouds), fused + again)
        self.assertEqual(len(set(m.header.stamp for m in self.clouds)), fused)
        published = fused if self.published_when_fused else fused + waiting
        self.assertEqual(published, len(set(m.header.stamp for m in self.depth)))
        depth_stamps = set(m.header.stamp for m in self.depth)
        self.assertTrue(all(m.header.stamp in depth_stamps for m in self.clouds))
        for msg in self.clouds:
            self.assertEqual(msg.header.frame_id, self.optical_frame)
            for p in pc2.read_points(msg, field_names=('x', 'y', 'z', 'normal_x', 'normal_y', 'normal_z')):
                self.assertTrue(all(math.isfinite(v) for v in p))

    def test_04_map(self):
        self.assertTrue(self.maps, 'no map received')
        msg = self.maps[-1]
        self.assertEqual(msg.header.frame_id, self.fixed_frame)
        points = list(pc2.read_points(msg, field_names=('x', 'y', 'z')))
        self.assertGreaterEqual(len(points), self.min_map_points)
        for p in points:
            self.assertTrue(all(math.isfinite(v) for v in p))
        if not self.bbox:
            rospy.loginfo('check_map: %d map points', len(points))
            return
        lo = [v - self.margin for v in self.bbox[:3]]
        hi = [v + self.margin for v in self.bbox[3:]]
        outside = [p for p in points if not all(lo[i] <= p[i] <= hi[i] for i in range(3))]
        distances = sorted(math.sqrt(sum(max(lo[i] - p[i], 0, p[i] - hi[i]) ** 2 for i in range(3)))
                           for p in outside)
        rospy.loginfo('check_map: %d map points, %d in the box widened by %.3f m, %d elsewhere (distance to the box: '
                      'median %.3f m, max %.3f m)', len(points), len(points) - len(outside), self.margin,
                      len(outside), distances[len(distances) // 2] if distances else 0,
                      distances[-1] if distances else 0)
        self.assertLessEqual(len(outside), self.max_fraction_elsewhere * len(points), outside[:10])

    def test_05_depth_against_truth(self):
        if not self.truth_topic:
            self.skipTest('no ~truth_topic')
        truth = {m.header.stamp: m for m in self.truth}
        latest = {m.header.stamp: m for m in self.depth}  # a refined depth map replaces the first
        errors, truth_pixels = [], 0
        for stamp, depth in latest.items():
            self.assertIn(stamp, truth)
            image_errors, image_truth_pixels = relative_errors(depth, truth[stamp])
            errors += image_errors
            truth_pixels += image_truth_pixels
        errors.sort()
        self.assertGreater(len(errors), 1000)
        median = errors[len(errors) // 2]
        within = 100.0 * sum(1 for e in errors if e <= 0.10) / len(errors)
        within_5pct = sum(1 for e in errors if e <= 0.05)
        truth_within_5pct = 100.0 * within_5pct / truth_pixels
        rospy.loginfo('check_map: %d depth images vs %s: median relative error %.2f %%, %.1f %% within 5 %%, '
                      '%.1f %% within 10 %% over %d pixels; %.1f %% of the truth\'s %d pixels within 5 %%',
                      len(latest), self.truth_topic, 100 * median, 100.0 * within_5pct / len(errors), within,
                      len(errors), truth_within_5pct, truth_pixels)
        self.assertLessEqual(median, self.max_median_error)
        self.assertGreaterEqual(within, self.min_within_10pct)
        self.assertGreaterEqual(truth_within_5pct, self.min_truth_within_5pct)

    def test_06_counters(self):
        if not self.min_counters and not self.max_counters:
            self.skipTest('no ~min_counters or ~max_counters')
        for name, floor in self.min_counters.items():
            self.assertGreaterEqual(int(self.diagnostics.get(name, -1)), floor, (name, self.diagnostics))
        for name, ceiling in self.max_counters.items():
            self.assertIn(name, self.diagnostics)
            self.assertLessEqual(int(self.diagnostics[name]), ceiling, (name, self.diagnostics))

    def test_07_map_against_true_surface(self):
        if not self.truth_dense_dir:
            self.skipTest('no ~truth_dense_dir')
        within = self.map_within(true_surface(self.truth_dense_dir), 0.02, 'the true surface')
        self.assertGreaterEqual(within, self.min_map_within_2cm)

    def test_08_map_against_truth_images(self):
        if not (self.min_map_within_5cm > 0 and self.truth_topic):
            self.skipTest('no ~min_map_within_5cm with a ~truth_topic')
        within = self.map_within(self.truth_surface(), 0.05, 'the surface of %d truth images' % len(self.truth))
        self.assertGreaterEqual(within, self.min_map_within_5cm)

    def test_09_mesh(self):
        if self.min_mesh_triangles <= 0:
            self.skipTest('no ~min_mesh_triangles')
        self.assertTrue(self.meshes, 'no mesh received')
        mesh = self.meshes[-1]
        self.assertEqual(mesh.type, Marker.TRIANGLE_LIST)
        self.assertEqual(mesh.header.frame_id, self.maps[-1].header.frame_id if self.maps else mesh.header.frame_id)
        self.assertEqual(len(mesh.points) % 3, 0)
        self.assertIn(len(mesh.colors), (0, len(mesh.points)))
        vertices = np.array([(p.x, p.y, p.z) for p in mesh.points])
        self.assertTrue(np.all(np.isfinite(vertices)), 'a NaN vertex in the mesh')
        rospy.loginfo('check_map: mesh of %d triangles', len(mesh.points) // 3)
        self.assertGreaterEqual(len(mesh.points) // 3, self.min_mesh_triangles)
        if self.min_mesh_within_5cm > 0 and self.truth_topic:
            unique = np.unique(vertices, axis=0)
            within = self.points_within(unique, self.truth_surface(), 0.05, 'mesh', 'the truth images')
            self.assertGreaterEqual(within, self.min_mesh_within_5cm)

    def truth_surface(self):
        """The truth images back-projected at the poses of their stamps (every other pixel)."""
        poses = {m.header.stamp: m.pose for m in self.poses}
        infos = {m.header.stamp: m for m in self.camera_infos}
        usable = [m for m in self.truth if m.header.stamp in poses and m.header.stamp in infos]
        self.assertEqual(len(usable), len(self.truth), 'a truth image without the pose or camera_info of its stamp')
        return np.concatenate([truth_image_points(m, infos[m.header.stamp], poses[m.header.stamp]) for m in usable])

    def points_within(self, points, surface_points, radius, what, surface_name):
        """Percent of `points` (up to ~map_sample, evenly spaced) within `radius` of a surface point."""
        step = max(1, len(points) // self.map_sample)
        sample = points[::step]
        surface = SurfaceIndex(surface_points, radius)
        within = 100.0 * sum(1 for p in sample if surface.within(p)) / len(sample)
        rospy.loginfo('check_map: %s %d points, %.1f %% of %d sampled within %g cm of %s', what, len(points), within,
                      len(sample), 100 * radius, surface_name)
        return within

    def map_within(self, surface_points, radius, surface_name):
        """Percent of the last map's sampled points within `radius` of a surface point."""
        self.assertTrue(self.maps, 'no map received')
        points = list(pc2.read_points(self.maps[-1], field_names=('x', 'y', 'z')))
        return self.points_within(points, surface_points, radius, 'map', surface_name)


def true_surface(dense_dir):
    """World points of every view's true depth (the readers of
    scripts/dense_folder_to_bag.py, which wrote the bag from the same folder)."""
    points = []  # one array per view
    for cam in sorted(glob.glob(os.path.join(dense_dir, 'cams_gt', '*_cam.txt'))):
        world_to_camera, intrinsic = read_cam(cam)
        name = os.path.basename(cam)[:-len('_cam.txt')]
        depth = read_pfm(os.path.join(dense_dir, 'depth_gt', name + '.pfm'))
        v, u = np.nonzero(np.isfinite(depth) & (depth > 0))
        z = depth[v, u]
        camera_points = np.stack([(u - intrinsic[0, 2]) / intrinsic[0, 0] * z,
                                  (v - intrinsic[1, 2]) / intrinsic[1, 1] * z, z], axis=1)
        rotation, translation = world_to_camera[:3, :3], world_to_camera[:3, 3]
        points.append((camera_points - translation) @ rotation)  # R^T (x - t), row-wise
    if not points:
        raise AssertionError(dense_dir + ': no true depth (cams_gt/, depth_gt/)')
    return np.concatenate(points)


def truth_image_points(truth, info, pose):
    """World points of every other pixel of a 32FC1 truth image with depth,
    through its camera_info's K and its camera-to-world pose."""
    depth = np.frombuffer(bytes(truth.data), dtype='<f4').reshape(truth.height, truth.width)[::2, ::2]
    v, u = np.nonzero(np.isfinite(depth) & (depth > 0))
    z = depth[v, u].astype(np.float64)
    u, v = 2.0 * u, 2.0 * v
    scale = truth.width / float(info.width)  # K of the camera_info's size, at the truth's
    fx, fy = info.K[0] * scale, info.K[4] * scale
    cx, cy = (info.K[2] + 0.5) * scale - 0.5, (info.K[5] + 0.5) * scale - 0.5
    camera_points = np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z], axis=1)
    rotation = np.array(quaternion_matrix(pose.orientation))  # camera-to-world
    position = np.array([pose.position.x, pose.position.y, pose.position.z])
    return camera_points @ rotation.T + position


class SurfaceIndex:
    """Points in cubic cells of the radius: is a query within the radius of one?"""

    def __init__(self, points, radius):
        self.radius = radius
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        keys = np.floor(points / radius).astype(np.int64)
        order = np.lexsort(keys.T[::-1])
        keys, points = keys[order], points[order]
        starts = np.flatnonzero(np.r_[True, np.any(keys[1:] != keys[:-1], axis=1)])
        ends = np.r_[starts[1:], len(points)]
        self.cells = {tuple(int(k) for k in keys[a]): points[a:b] for a, b in zip(starts, ends)}

    def cell(self, p):
        return tuple(int(math.floor(c / self.radius)) for c in p)

    def within(self, p):
        cx, cy, cz = self.cell(p)
        q = np.asarray(p, dtype=np.float64)
        r2 = self.radius * self.radius
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    cell = self.cells.get((cx + dx, cy + dy, cz + dz))
                    if cell is not None and np.min(np.sum((cell - q) ** 2, axis=1)) <= r2:
                        return True
        return False


def relative_errors(depth, truth):
    """(|depth - truth| / truth where both are finite and > 0, the number of
    pixels where the truth is); the truth sampled at the nearest pixel centre
    when its size differs."""
    values = struct.unpack('<%df' % (depth.width * depth.height), bytes(depth.data))
    reference = struct.unpack('<%df' % (truth.width * truth.height), bytes(truth.data))
    errors, truth_pixels = [], 0
    for v in range(depth.height):
        tv = min(int((v + 0.5) * truth.height / depth.height), truth.height - 1)
        for u in range(depth.width):
            d = values[v * depth.width + u]
            t = reference[tv * truth.width + min(int((u + 0.5) * truth.width / depth.width), truth.width - 1)]
            if not (t > 0 and math.isfinite(t)):
                continue
            truth_pixels += 1
            if d > 0 and math.isfinite(d):
                errors.append(abs(d - t) / t)
    return errors, truth_pixels


if __name__ == '__main__':
    rostest.rosrun('amhmvs_mapping', 'check_map', MapReplay, sys.argv)
