#!/usr/bin/env python3
"""Session 20: where the realism map's 2 cm misses come from, per keyframe.

Reads an MVSNet realism folder DATA (cams/ = tracker, cams_gt/ = truth,
depth_gt/) and an `amhmvs_map` output OUT (depth/NNNNNN.pfm, clouds/NNNNNN.ply
in the world frame at the tracker's pose).

  ratios DATA OUT
      per keyframe: median estimated / true depth, the share within 1 %,
      and the share within 1 % after dividing by that median (one scale).
  edges DATA OUT DEBUG
      per refined pair of the last pose-graph solve: refined, graph and
      tracker baseline length / true length, and the reference's star scale.
  place DATA OUT POSES [SCALE]
      each keyframe's cloud taken to its camera frame (tracker pose), scaled
      (SCALE: 'oracle' = divided by its median depth ratio, or a file of
      'id scale' lines), placed at POSES ('gt', or the graph's POSE lines of
      DEBUG) and compared with the true depth along the true camera's ray:
      the share within 2 / 5 cm per keyframe and for all points.

DEBUG is the stderr of an experiment build of amhmvs_map with
AMHMVS_PRINT_STAR_SCALES=1 (an experiment patch, not kept):
lines 'STAR id scale', 'EDGE ref src refined_length graph_length' and
'POSE id r00 .. r23' (camera-to-world), one block per graph solve.
Reads cams and PFMs with scripts/dense_folder_to_bag.py's readers, so it
needs numpy and the ROS Python modules that script imports (/usr/bin/python3
here).
"""
import collections
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from dense_folder_to_bag import read_cam, read_pfm  # noqa: E402  (MVSNet cam.txt and PFM readers)

KEYFRAMES = 8


def centre(world_to_camera):
    return -world_to_camera[:3, :3].T @ world_to_camera[:3, 3]


def read_cloud(path):
    raw = open(path, 'rb').read()
    start = raw.index(b'end_header\n') + len(b'end_header\n')
    vertex = np.dtype([('x', '<f4'), ('y', '<f4'), ('z', '<f4'), ('nx', '<f4'), ('ny', '<f4'), ('nz', '<f4'),
                       ('r', 'u1'), ('g', 'u1'), ('b', 'u1'), ('q', '<f4')])
    points = np.frombuffer(raw[start:], vertex)
    return np.stack([points['x'], points['y'], points['z']], 1).astype(float)


def true_depth_along_rays(camera_points, intrinsics, truth):
    """The true depth at each point's pixel (NaN outside the image)."""
    height, width = truth.shape
    uvw = (intrinsics @ camera_points.T).T
    u = np.round(uvw[:, 0] / uvw[:, 2]).astype(int)
    v = np.round(uvw[:, 1] / uvw[:, 2]).astype(int)
    inside = (u >= 0) & (u < width) & (v >= 0) & (v < height)
    depth = np.full(len(camera_points), np.nan)
    depth[inside] = truth[v[inside], u[inside]]
    return depth


def last_debug_block(path):
    lines = [line.split() for line in open(path) if line.strip()]
    starts = [i for i, f in enumerate(lines) if f[0] == 'STAR' and (i == 0 or lines[i - 1][0] != 'STAR')]
    return lines[starts[-1]:] if starts else lines


def ratios(data, out):
    for k in range(KEYFRAMES):
        estimate = read_pfm('%s/depth/%06d.pfm' % (out, k))
        truth = read_pfm('%s/depth_gt/%08d.pfm' % (data, k))
        valid = np.isfinite(estimate) & (estimate > 0) & np.isfinite(truth) & (truth > 0)
        ratio = estimate[valid] / truth[valid]
        median = np.median(ratio)
        print('%d median ratio %.4f  within 1 %%: %.1f  after one scale: %.1f' %
              (k, median, 100 * np.mean(np.abs(ratio - 1) < 0.01), 100 * np.mean(np.abs(ratio / median - 1) < 0.01)))


def edges(data, out, debug):
    block = last_debug_block(debug)
    star = {int(f[1]): float(f[2]) for f in block if f[0] == 'STAR'}
    true_centre = {k: centre(read_cam('%s/cams_gt/%08d_cam.txt' % (data, k))[0]) for k in range(KEYFRAMES)}
    tracker_centre = {k: centre(read_cam('%s/cams/%08d_cam.txt' % (data, k))[0]) for k in range(KEYFRAMES)}
    per_reference = collections.defaultdict(list)
    for f in block:
        if f[0] != 'EDGE':
            continue
        i, j, refined, graph = int(f[1]), int(f[2]), float(f[3]), float(f[4])
        true_length = np.linalg.norm(true_centre[j] - true_centre[i])
        tracker_length = np.linalg.norm(tracker_centre[j] - tracker_centre[i])
        per_reference[i].append((j, refined / true_length, graph / true_length, tracker_length / true_length))
    for i in sorted(per_reference):
        pairs = ' '.join('%d: refined %.3f graph %.3f tracker %.3f' % p for p in per_reference[i])
        print('kf%d star %.4f | %s' % (i, star.get(i, float('nan')), pairs))


def place(data, out, poses_from, scale_from=None):
    graph_poses = {}
    if poses_from != 'gt':
        for f in last_debug_block(poses_from):
            if f[0] == 'POSE':
                pose = np.eye(4)
                pose[:3, :] = np.array(list(map(float, f[2:]))).reshape(3, 4)
                graph_poses[int(f[1])] = pose
    scales = {}
    if scale_from and scale_from != 'oracle':
        scales = {int(a): float(b) for a, b in (line.split() for line in open(scale_from) if line.strip())}
    errors = []
    for k in range(KEYFRAMES):
        world = read_cloud('%s/clouds/%06d.ply' % (out, k))
        tracker, intrinsics = read_cam('%s/cams/%08d_cam.txt' % (data, k))
        true_pose, _ = read_cam('%s/cams_gt/%08d_cam.txt' % (data, k))
        truth = read_pfm('%s/depth_gt/%08d.pfm' % (data, k))
        camera = (tracker[:3, :3] @ world.T + tracker[:3, 3:4]).T
        if scale_from == 'oracle':
            camera /= np.nanmedian(camera[:, 2] / true_depth_along_rays(camera, intrinsics, truth))
        else:
            camera *= scales.get(k, 1.0)
        camera_to_world = np.linalg.inv(true_pose) if poses_from == 'gt' else graph_poses[k]
        placed = (camera_to_world[:3, :3] @ camera.T + camera_to_world[:3, 3:4]).T
        in_true_camera = (true_pose[:3, :3] @ placed.T + true_pose[:3, 3:4]).T
        error = np.abs(in_true_camera[:, 2] - true_depth_along_rays(in_true_camera, intrinsics, truth))
        error[~np.isfinite(error)] = np.inf
        errors.append(error)
        print('%d %.1f' % (k, 100 * np.mean(error < 0.02)), end='  ')
    everything = np.concatenate(errors)
    print('| all: %.1f %% within 2 cm, %.1f %% within 5 cm' %
          (100 * np.mean(everything < 0.02), 100 * np.mean(everything < 0.05)))


if __name__ == '__main__':
    commands = {'ratios': ratios, 'edges': edges, 'place': place}
    if len(sys.argv) < 4 or sys.argv[1] not in commands:
        sys.exit(__doc__)
    commands[sys.argv[1]](*sys.argv[2:])
