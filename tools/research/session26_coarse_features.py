#!/usr/bin/env python3
"""Session 26: the realism map's 2 cm misses are far walls whose depth is
0.1-0.6 % short, from relative rotations a few hundredths of a degree off;
on sharp images the keyframe bundle adjustment turns them because coarse SIFT
blobs' centres move with the viewing angle.

DATA is an MVSNet realism folder (cams/ = tracker, cams_gt/ = truth,
depth_gt/), OUT an `amhmvs_map` output (depth/, clouds/, keyframe_poses.txt).

  walls DATA OUT
      per keyframe, on the farthest 30 % of the true pixels: the written
      depth's and the fused cloud's median signed error and share within
      0.5 %; with OUT's summary.json also the depth's median error at the
      map's own scale (times the similarity's scale to the true poses).
  pairs DATA:OUT [DATA:OUT ...]
      each consecutive keyframe pair's relative rotation error of the map's
      poses (keyframe_poses.txt) against the truth, as a rotation vector in
      the first camera's frame (degrees; y is the yaw of a sideways walk),
      then each component's signed mean over the pairs (a bias shared by
      the pairs bends the map) and the mean absolute component.
  export DATA FILE [--truth] [--max_size S] [--gap G] [--features N]
      SIFT features (OpenCV, all of them; optionally only those of size <= S,
      or the N strongest as the pipeline's max_features) of every image, their
      sizes, and the RANSAC inlier matches of each pair at most G (3) apart,
      with the tracker's cameras (or the true ones with
      --truth): the input of session26_adjust_keyframes.cpp, which runs
      mapping/keyframe_bundle_adjustment.h on it. Then `pairs` on its output
      (POSES given as DATA:POSES with --poses).

Needs numpy and OpenCV's Python module (/usr/bin/python3 here).
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', '..', 'scripts'))
sys.path.insert(0, HERE)
from dense_folder_to_bag import read_cam, read_pfm  # noqa: E402
from session20_scale_decomposition import read_cloud  # noqa: E402
from session25_thin_voxels import map_poses  # noqa: E402

SIFT_UPSAMPLING_OFFSET = 0.25  # as src/pose_refinement/feature_matching.cpp


def rotation_vector_deg(rotation):
    angle = np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])
    return np.degrees(angle / (2 * np.sin(angle)) * axis)


def true_poses(data, ids):
    return {k: np.linalg.inv(read_cam('%s/cams_gt/%08d_cam.txt' % (data, k))[0]) for k in ids}


def walls(data, out):
    scale = None
    if os.path.exists(out + '/summary.json'):
        import json
        aligned = json.load(open(out + '/summary.json'))['map'].get('after_similarity_to_true_poses')
        scale = aligned['scale'] if aligned else None
    for k in sorted(map_poses(out)):
        world_to_camera, intrinsics = read_cam('%s/cams/%08d_cam.txt' % (data, k))
        truth = read_pfm('%s/depth_gt/%08d.pfm' % (data, k)).astype(float)
        far = truth > np.nanpercentile(truth, 70)
        depth = read_pfm('%s/depth/%06d.pfm' % (out, k)).astype(float)
        camera = read_cloud('%s/clouds/%06d.ply' % (out, k)) @ world_to_camera[:3, :3].T + world_to_camera[:3, 3]
        u = np.round(intrinsics[0, 0] * camera[:, 0] / camera[:, 2] + intrinsics[0, 2]).astype(int)
        v = np.round(intrinsics[1, 1] * camera[:, 1] / camera[:, 2] + intrinsics[1, 2]).astype(int)
        inside = (u >= 0) & (u < truth.shape[1]) & (v >= 0) & (v < truth.shape[0])
        cloud = np.full(truth.shape, np.nan)
        cloud[v[inside], u[inside]] = camera[inside, 2]
        line = ['keyframe %d, far walls at %.2f m:' % (k, np.nanmedian(truth[far]))]
        if scale is not None:
            # The depth against the map's own scale (the similarity to the
            # true poses multiplies the map by `scale`): what bends the map.
            error = (depth * scale - truth) / truth
            line.append('depth at the map\'s scale median %+.2f %%,' % (100 * np.nanmedian(error[far])))
        for name, values in (('depth', depth), ('cloud', cloud)):
            error = (values - truth) / truth
            chosen = far & np.isfinite(error)
            line.append('%s median %+.2f %%, %.1f %% within 0.5 %% (%d px)' %
                        (name, 100 * np.median(error[chosen]), 100 * np.mean(np.abs(error[chosen]) <= 0.005), chosen.sum()))
        print(' '.join(line))


def pairs(runs, poses_file=False):
    for run in runs:
        data, out = run.split(':')
        if poses_file:
            poses = {}
            for line in open(out):
                values = line.split()
                poses[int(values[0])] = np.array([float(x) for x in values[1:]]).reshape(4, 4)
        else:
            poses = map_poses(out)
        truth = true_poses(data, poses)
        ids = sorted(poses)
        errors = []
        for a, b in zip(ids, ids[1:]):
            mapped = np.linalg.inv(poses[a]) @ poses[b]
            true = np.linalg.inv(truth[a]) @ truth[b]
            errors.append(rotation_vector_deg(mapped[:3, :3] @ true[:3, :3].T))
        print(out, ' '.join('(%+.3f %+.3f %+.3f)' % tuple(e) for e in errors),
              'signed mean (%+.4f %+.4f %+.4f)' % tuple(np.mean(errors, axis=0)),
              'mean abs %.4f' % np.mean(np.abs(errors)))


def export(data, path, use_truth, max_size, gap=3, count=0):
    import cv2
    features = {}
    with open(path, 'w') as out:
        k = 0
        while os.path.exists('%s/images/%08d.png' % (data, k)):
            world_to_camera, intrinsics = read_cam('%s/%s/%08d_cam.txt' % (data, 'cams_gt' if use_truth else 'cams', k))
            image = cv2.imread('%s/images/%08d.png' % (data, k), cv2.IMREAD_GRAYSCALE)
            keypoints, descriptors = cv2.SIFT_create(count).detectAndCompute(image, None)
            keep = [i for i, p in enumerate(keypoints) if p.size <= max_size]
            keypoints, descriptors = [keypoints[i] for i in keep], descriptors[keep]
            pixels = np.array([p.pt for p in keypoints]) - SIFT_UPSAMPLING_OFFSET
            features[k] = (intrinsics, pixels, descriptors)
            out.write('K %d %d %d %r %r %r %r %s\n' % (k, image.shape[1], image.shape[0], intrinsics[0, 0], intrinsics[1, 1],
                                                      intrinsics[0, 2], intrinsics[1, 2],
                                                      ' '.join(repr(v) for v in world_to_camera[:3, :4].ravel())))
            out.write('F %d %d %s\n' % (k, len(pixels), ' '.join('%r %r' % tuple(p) for p in pixels)))
            out.write('S %d %d %s\n' % (k, len(keypoints), ' '.join('%r' % p.size for p in keypoints)))
            k += 1
        for i in range(k):
            for j in range(i + 1, min(k, i + 1 + gap)):
                (Ki, pi, di), (Kj, pj, dj) = features[i], features[j]
                best = {}
                for first, second in cv2.BFMatcher(cv2.NORM_L2).knnMatch(di, dj, k=2):
                    if first.distance <= 0.8 * second.distance and (first.trainIdx not in best or
                                                                  first.distance < best[first.trainIdx].distance):
                        best[first.trainIdx] = first
                matches = list(best.values())
                a = (pi[[m.queryIdx for m in matches]] - Ki[:2, 2]) / Ki[0, 0]
                b = (pj[[m.trainIdx for m in matches]] - Kj[:2, 2]) / Kj[0, 0]
                _, mask = cv2.findEssentialMat(a, b, np.eye(3), cv2.RANSAC, 0.999, 1.5 / Ki[0, 0])
                inliers = [m for m, ok in zip(matches, mask.ravel()) if ok]
                out.write('M %d %d %d %s\n' % (i, j, len(inliers), ' '.join('%d %d' % (m.queryIdx, m.trainIdx) for m in inliers)))


if __name__ == '__main__':
    command, arguments = sys.argv[1], sys.argv[2:]
    if command == 'walls':
        walls(*arguments)
    elif command == 'pairs':
        pairs([a for a in arguments if a != '--poses'], '--poses' in arguments)
    elif command == 'export':
        max_size = float(arguments[arguments.index('--max_size') + 1]) if '--max_size' in arguments else np.inf
        def number(flag, default):
            return type(default)(arguments[arguments.index(flag) + 1]) if flag in arguments else default
        export(arguments[0], arguments[1], '--truth' in arguments, max_size, number('--gap', 3), number('--features', 0))
    else:
        sys.exit(__doc__)
