#!/usr/bin/env python3
"""Session 29: does aligning image patches make the keyframe bundle
adjustment's matches more precise than SIFT's own positions? (No: measured
against the true correspondences the error stays 0.19 px median; see
realism_map_session14.md, session 29.)

  align EXPORT IMAGES OUT [RADIUS [SMOOTH]]
      EXPORT as `session26_coarse_features.py export` writes it. The matches
      are joined into tracks; each observation but the track's first (lowest
      keyframe) is moved to where its patch (2 RADIUS + 1 square, Gaussian
      weights; RADIUS 5) best matches the first's, with a gain and an offset
      (Gauss-Newton, images optionally smoothed by SMOOTH px). Writes EXPORT
      with the moved pixels to OUT for session26_adjust_keyframes.cpp.
  check DATA EXPORT_A EXPORT_B
      for every match (i, j): the position in j against the true
      correspondence (the pixel in i through the true depth and the true
      cameras of DATA); median, 75th percentile and mean of the error.

Needs numpy and OpenCV's Python module (/usr/bin/python3 here).
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', '..', 'scripts'))
from dense_folder_to_bag import read_cam, read_pfm  # noqa: E402


def read_export(path):
    lines = open(path).read().splitlines()
    features, matches = {}, []
    for line in lines:
        t = line.split()
        if t[0] == 'F':
            features[int(t[1])] = np.array(t[3:3 + 2 * int(t[2])], float).reshape(-1, 2)
        elif t[0] == 'M':
            n = int(t[3])
            matches.append((int(t[1]), int(t[2]), np.array(t[4:4 + 2 * n], int).reshape(n, 2)))
    return lines, features, matches


def tracks_of(matches):
    parent = {}

    def find(a):
        while parent.setdefault(a, a) != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for i, j, pairs in matches:
        for a, b in pairs:
            ra, rb = find((i, a)), find((j, b))
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    tracks = {}
    for node in list(parent):
        tracks.setdefault(find(node), []).append(node)
    return tracks


def bilinear(image, xs, ys):
    h, w = image.shape
    x0, y0 = np.floor(xs).astype(int), np.floor(ys).astype(int)
    fx, fy = xs - x0, ys - y0
    inside = ((x0 >= 0) & (y0 >= 0) & (x0 < w - 1) & (y0 < h - 1)).all()
    x0, y0 = np.clip(x0, 0, w - 2), np.clip(y0, 0, h - 2)
    return (image[y0, x0] * (1 - fx) * (1 - fy) + image[y0, x0 + 1] * fx * (1 - fy) +
            image[y0 + 1, x0] * (1 - fx) * fy + image[y0 + 1, x0 + 1] * fx * fy), inside


def align(export, images, out, radius=5, smooth=0.0):
    import cv2
    lines, features, matches = read_export(export)
    pictures = {}
    for k in features:
        picture = cv2.imread('%s/%08d.png' % (images, k), cv2.IMREAD_GRAYSCALE).astype(np.float64)
        pictures[k] = cv2.GaussianBlur(picture, (0, 0), smooth) if smooth > 0 else picture
    steps = np.arange(-radius, radius + 1, dtype=float)
    dx, dy = [a.ravel() for a in np.meshgrid(steps, steps)]
    weights = np.exp(-(dx ** 2 + dy ** 2) / (2 * (radius / 2.0) ** 2))
    moved = {k: f.copy() for k, f in features.items()}
    shifts = []
    for (first_k, first_f), nodes in tracks_of(matches).items():
        p = features[first_k][first_f]
        template, inside = bilinear(pictures[first_k], p[0] + dx, p[1] + dy)
        if not inside:
            continue
        for k, f in nodes:
            if (k, f) == (first_k, first_f):
                continue
            q, converged = features[k][f].copy(), False
            for _ in range(20):
                values, inside = bilinear(pictures[k], q[0] + dx, q[1] + dy)
                if not inside:
                    break
                gx = bilinear(pictures[k], q[0] + dx + 0.5, q[1] + dy)[0] - bilinear(pictures[k], q[0] + dx - 0.5, q[1] + dy)[0]
                gy = bilinear(pictures[k], q[0] + dx, q[1] + dy + 0.5)[0] - bilinear(pictures[k], q[0] + dx, q[1] + dy - 0.5)[0]
                # template = a I(q + step) + b, linearised: unknowns a step, a - 1, b.
                jacobian = np.stack([gx, gy, values, np.ones_like(values)], 1)
                try:
                    solution = np.linalg.solve(jacobian.T @ (jacobian * weights[:, None]),
                                               jacobian.T @ (weights * (template - values)))
                except np.linalg.LinAlgError:
                    break
                step = solution[:2] / (1 + solution[2])
                q += step
                if np.hypot(*step) < 1e-3:
                    converged = True
                    break
            if converged and np.hypot(*(q - features[k][f])) < 1.5:
                shifts.append(q - features[k][f])
                moved[k][f] = q
    shifts = np.array(shifts)
    print('moved %d observations: median %.3f px, rms %.3f px' %
          (len(shifts), np.median(np.hypot(*shifts.T)), np.sqrt((shifts ** 2).sum(1).mean())), file=sys.stderr)
    with open(out, 'w') as written:
        for line in lines:
            t = line.split()
            if t[0] == 'F':
                k = int(t[1])
                written.write('F %d %d %s\n' % (k, len(moved[k]), ' '.join('%r %r' % tuple(p) for p in moved[k])))
            else:
                written.write(line + '\n')


def check(data, *exports):
    loaded = [read_export(e) for e in exports]
    ids = loaded[0][1].keys()
    cams = {k: read_cam('%s/cams_gt/%08d_cam.txt' % (data, k)) for k in ids}
    depth = {k: read_pfm('%s/depth_gt/%08d.pfm' % (data, k)) for k in ids}
    for name, (_, features, _) in zip(exports, loaded):
        errors = []
        for i, j, pairs in loaded[0][2]:
            (world_to_i, K_i), (world_to_j, K_j) = cams[i], cams[j]
            for a, b in pairs:
                p = features[i][a]
                z = depth[i][int(round(p[1])), int(round(p[0]))]
                if not np.isfinite(z):
                    continue
                world = np.linalg.inv(world_to_i) @ np.r_[np.linalg.inv(K_i) @ np.array([p[0], p[1], 1]) * z, 1]
                q = K_j @ (world_to_j @ world)[:3]
                errors.append(features[j][b] - q[:2] / q[2])
        errors = np.array(errors)
        r = np.hypot(*errors.T)
        print('%s: median %.3f px, 75th percentile %.3f px, mean (%+.3f %+.3f) px' %
              (name, np.median(r), np.percentile(r, 75), *errors.mean(0)))


if __name__ == '__main__':
    command, arguments = sys.argv[1], sys.argv[2:]
    if command == 'align':
        align(arguments[0], arguments[1], arguments[2], *(t(a) for t, a in zip((int, float), arguments[3:])))
    elif command == 'check':
        check(*arguments)
    else:
        sys.exit(__doc__)
