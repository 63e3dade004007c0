#!/usr/bin/env python3
"""Session 25: the realism map's 2 cm misses are its thin voxels.

Reads an MVSNet realism folder DATA (cams/ = tracker, cams_gt/ = truth,
depth_gt/) and `amhmvs_map` outputs OUT (clouds/NNNNNN.ply: each keyframe's
fused points in the world at the tracker's pose; keyframe_poses.txt: where
the map placed each keyframe, TUM format, keyframe k at stamp 0.5 k).

The true surface is DATA's depth_gt back-projected at the true poses, and a
point's distance to it the distance to its nearest sample, as amhmvs_map's
summary measures it. The nearest sample is searched among the 5x5 pixels
around the point's projection into every true view.

  floor DATA
      points exactly on the true surface between its samples (depth
      interpolated at half-pixel offsets, away from depth edges): the share
      within 1 / 2 cm of the nearest sample. What the measure itself costs.
  support DATA OUT
      the map rebuilt from the clouds at the map's poses (2 cm voxels, mean
      point, as mapping/voxel_map.h): within 2 cm per number of points and
      of keyframes in a voxel.
  curve align|asis DATA:OUT [DATA:OUT ...]
      per min_points_per_voxel 1..8: the map within 2 cm (align: after the
      similarity of eval/pose_alignment.h from the map's keyframe poses to the
      true ones) and each keyframe's pixels whose fused point is in a kept
      voxel (least / median over keyframes); then the mean over the runs,
      the worst run, and the means of least and median.

Needs numpy and the ROS Python modules that scripts/dense_folder_to_bag.py
imports (/usr/bin/python3 here).
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', '..', 'scripts'))
sys.path.insert(0, HERE)
from dense_folder_to_bag import read_cam, read_pfm  # noqa: E402  (MVSNet cam.txt and PFM readers)
from session20_scale_decomposition import read_cloud  # noqa: E402  (amhmvs_map's cloud PLY)

VOXEL = 0.02
FRAME_PERIOD = 0.5  # amhmvs_synthetic's stamps


class Truth:
    """The true views of a realism folder and their back-projected depth."""

    def __init__(self, data):
        self.data = data
        self.views = []
        k = 0
        while os.path.exists('%s/cams_gt/%08d_cam.txt' % (data, k)):
            world_to_camera, intrinsics = read_cam('%s/cams_gt/%08d_cam.txt' % (data, k))
            depth = read_pfm('%s/depth_gt/%08d.pfm' % (data, k)).astype(float)
            height, width = depth.shape
            v, u = np.mgrid[0:height, 0:width]
            samples = backproject(world_to_camera, intrinsics, u.ravel(), v.ravel(), depth.ravel())
            self.views.append((world_to_camera, intrinsics, depth, samples.reshape(height, width, 3)))
            k += 1

    def nearest(self, points):
        """Distance of each world point to its nearest true sample."""
        best = np.full(len(points), np.inf)
        for world_to_camera, intrinsics, depth, samples in self.views:
            height, width = depth.shape
            u, v, ahead = project(world_to_camera, intrinsics, points)
            u = np.where(ahead, np.round(u), -99).astype(int)
            v = np.where(ahead, np.round(v), -99).astype(int)
            for du in range(-2, 3):
                for dv in range(-2, 3):
                    a, b = u + du, v + dv
                    inside = (a >= 0) & (a < width) & (b >= 0) & (b < height)
                    distance = np.linalg.norm(samples[np.clip(b, 0, height - 1), np.clip(a, 0, width - 1)] - points, axis=1)
                    distance[~inside | ~np.isfinite(distance)] = np.inf
                    best = np.minimum(best, distance)
        return best


def backproject(world_to_camera, intrinsics, u, v, z):
    camera = np.stack([(u - intrinsics[0, 2]) / intrinsics[0, 0] * z, (v - intrinsics[1, 2]) / intrinsics[1, 1] * z, z], 1)
    return (camera - world_to_camera[:3, 3]) @ world_to_camera[:3, :3]


def project(world_to_camera, intrinsics, points):
    camera = points @ world_to_camera[:3, :3].T + world_to_camera[:3, 3]
    ahead = camera[:, 2] > 0
    z = np.maximum(camera[:, 2], 1e-9)
    return intrinsics[0, 0] * camera[:, 0] / z + intrinsics[0, 2], intrinsics[1, 1] * camera[:, 1] / z + intrinsics[1, 2], ahead


def rotation_of_quaternion(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def map_poses(out):
    """keyframe id -> camera-to-world 4x4 of keyframe_poses.txt."""
    poses = {}
    for line in open(out + '/keyframe_poses.txt'):
        if line.startswith('#'):
            continue
        values = [float(word) for word in line.split()]
        pose = np.eye(4)
        pose[:3, :3] = rotation_of_quaternion(*values[4:8])
        pose[:3, 3] = values[1:4]
        poses[int(round(values[0] / FRAME_PERIOD))] = pose
    return poses


def placed_points(truth, out):
    """All keyframes' fused points where the map placed them, and each point's keyframe."""
    poses = map_poses(out)
    points, keyframe = [], []
    for k in sorted(poses):
        cloud = read_cloud('%s/clouds/%06d.ply' % (out, k))
        tracker_world_to_camera, _ = read_cam('%s/cams/%08d_cam.txt' % (truth.data, k))
        camera = cloud @ tracker_world_to_camera[:3, :3].T + tracker_world_to_camera[:3, 3]
        points.append(camera @ poses[k][:3, :3].T + poses[k][:3, 3])
        keyframe.append(np.full(len(cloud), k))
    return np.concatenate(points), np.concatenate(keyframe), poses


def voxelise(points):
    """Voxel of each point (index into the voxels), the voxels' mean points and point counts."""
    _, voxel_of_point, counts = np.unique(np.floor(points / VOXEL).astype(np.int64), axis=0, return_inverse=True,
                                          return_counts=True)
    voxel_of_point = voxel_of_point.ravel()
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, voxel_of_point, points)
    return voxel_of_point, sums / counts[:, None], counts


def similarity_to_truth(truth, poses):
    """eval/pose_alignment.h: chordal mean rotation, then scale and translation of the centres."""
    ids = sorted(poses)
    true = [np.linalg.inv(truth.views[k][0]) for k in ids]
    mapped = [poses[k] for k in ids]
    u, _, vt = np.linalg.svd(sum(t[:3, :3] @ m[:3, :3].T for m, t in zip(mapped, true)))
    rotation = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    source = np.array([m[:3, 3] for m in mapped])
    target = np.array([t[:3, 3] for t in true])
    a = (source - source.mean(0)) @ rotation.T
    b = target - target.mean(0)
    scale = (a * b).sum() / (a * a).sum()
    return lambda p: scale * p @ rotation.T + (target.mean(0) - scale * rotation @ source.mean(0))


def floor(data):
    truth = Truth(data)
    for k, (world_to_camera, intrinsics, depth, _) in enumerate(truth.views):
        corners = [depth[:-1, :-1], depth[:-1, 1:], depth[1:, :-1], depth[1:, 1:]]
        middle = sum(corners) / 4
        smooth = np.isfinite(middle) & (np.maximum.reduce(corners) < 1.01 * np.minimum.reduce(corners))
        v, u = np.nonzero(smooth)
        distance = truth.nearest(backproject(world_to_camera, intrinsics, u + 0.5, v + 0.5, middle[v, u]))
        print('keyframe %d: %d points between samples, within 1 / 2 cm: %.1f / %.2f %%, median %.1f mm' %
              (k, len(distance), 100 * np.mean(distance <= 0.01), 100 * np.mean(distance <= 0.02), 1000 * np.median(distance)))


def support(data, out):
    truth = Truth(data)
    points, keyframe, _ = placed_points(truth, out)
    voxel_of_point, voxels, counts = voxelise(points)
    near = truth.nearest(voxels) <= 0.02
    print('%s: %d voxels, %.1f %% within 2 cm; %.1f %% of the points' %
          (out, len(voxels), 100 * near.mean(), 100 * np.mean(truth.nearest(points) <= 0.02)))
    for low, high in ((1, 1), (2, 2), (3, 4), (5, 8), (9, None)):
        chosen = (counts >= low) & (counts <= (high or counts.max()))
        print('  %s points: %4.1f %% of the voxels, %5.1f %% within 2 cm' %
              ('%d-%s' % (low, high or ''), 100 * chosen.mean(), 100 * near[chosen].mean()))
    seen_by = np.zeros((len(counts), keyframe.max() + 1), bool)
    seen_by[voxel_of_point, keyframe] = True
    keyframes = seen_by.sum(1)
    for n in range(1, keyframes.max() + 1):
        chosen = keyframes == n
        print('  %d keyframes: %4.1f %% of the voxels, %5.1f %% within 2 cm' % (n, 100 * chosen.mean(), 100 * near[chosen].mean()))


def curve(align, runs):
    rows = []
    for run in runs:
        data, out = run.split(':')
        truth = Truth(data)
        points, keyframe, poses = placed_points(truth, out)
        voxel_of_point, voxels, counts = voxelise(points)
        if align:
            voxels = similarity_to_truth(truth, poses)(voxels)
        near = truth.nearest(voxels) <= 0.02
        pixels = truth.views[0][2].size
        row = []
        for least_points in range(1, 9):
            kept = counts >= least_points
            kept_point = kept[voxel_of_point]
            shares = [100 * kept_point[keyframe == k].sum() / pixels for k in sorted(poses)]
            row.append((100 * near[kept].mean(), min(shares), np.median(shares)))
        rows.append(row)
        print(out, ' '.join('%d: %.1f %% %.0f/%.0f' % (n + 1, *values) for n, values in enumerate(row)), flush=True)
    rows = np.array(rows)
    print('min_points_per_voxel: map within 2 cm mean (worst run); pixels in the map, least / median (means)')
    for n in range(8):
        print('%d: %.1f (%.1f); %.1f / %.1f' % (n + 1, rows[:, n, 0].mean(), rows[:, n, 0].min(), rows[:, n, 1].mean(),
                                               rows[:, n, 2].mean()))


if __name__ == '__main__':
    if len(sys.argv) == 3 and sys.argv[1] == 'floor':
        floor(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == 'support':
        support(sys.argv[2], sys.argv[3])
    elif len(sys.argv) >= 4 and sys.argv[1] == 'curve' and sys.argv[2] in ('align', 'asis'):
        curve(sys.argv[2] == 'align', sys.argv[3:])
    else:
        sys.exit(__doc__)
