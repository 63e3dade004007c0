"""Agreement of depth images and point clouds with the fountain's triangulated
SIFT points (sparse_points.txt), as sparsePointAccuracy() in
src/eval/depth_metrics.cpp: for every observation of a point by a view, the
depth at the point's nearest pixel against the point's z-depth; the fraction
within 1 / 2 / 5 % relative error (a missing depth counts as a miss)."""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from dense_folder_to_bag import quaternion_matrix  # noqa: E402  (the bag writer's own conversion)

THRESHOLDS = (0.01, 0.02, 0.05)


def read_sparse_points(path):
    """[(x, y, z), set(view ids)] of every point."""
    points = []
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            values = line.split()
            count = int(values[3])
            points.append(((float(values[0]), float(values[1]), float(values[2])),
                           set(int(v) for v in values[4:4 + count])))
    return points


class Camera:
    """Pinhole camera from a CameraInfo (K, size) and a camera-to-world Pose."""

    def __init__(self, info, pose):
        self.fx, self.cx, self.fy, self.cy = info.K[0], info.K[2], info.K[4], info.K[5]
        self.width, self.height = info.width, info.height
        self.R = quaternion_matrix(pose.orientation)  # camera-to-world rotation
        self.C = (pose.position.x, pose.position.y, pose.position.z)

    def to_camera(self, p):
        d = [p[i] - self.C[i] for i in range(3)]
        return [sum(self.R[r][c] * d[r] for r in range(3)) for c in range(3)]

    def pixel(self, p):
        """(u, v, z) nearest pixel and z-depth of world point p, or None."""
        x, y, z = self.to_camera(p)
        if z <= 0:
            return None
        u, v = int(round(self.fx * x / z + self.cx)), int(round(self.fy * y / z + self.cy))
        if 0 <= u < self.width and 0 <= v < self.height:
            return u, v, z
        return None


def agreement(depth_at, camera, view_id, points):
    """(observations, with a finite depth, [within 1 %, 2 %, 5 %]) of one view;
    depth_at(u, v) -> metres or nan."""
    total, finite, within = 0, 0, [0, 0, 0]
    for position, views in points:
        if view_id not in views:
            continue
        hit = camera.pixel(position)
        if hit is None:
            continue
        u, v, z = hit
        total += 1
        d = depth_at(u, v)
        if not math.isfinite(d):
            continue
        finite += 1
        error = abs(d - z) / z
        for i, t in enumerate(THRESHOLDS):
            within[i] += error < t
    return total, finite, within


def render_depth(world_points, camera, splat_radius=1):
    """Z-buffer {(u, v): nearest z} of world points, each written to the
    (2 r + 1)^2 pixels around its projection (as renderPointDepth())."""
    zbuffer = {}
    for p in world_points:
        hit = camera.pixel(p)
        if hit is None:
            continue
        u, v, z = hit
        for dv in range(-splat_radius, splat_radius + 1):
            for du in range(-splat_radius, splat_radius + 1):
                key = (u + du, v + dv)
                if z < zbuffer.get(key, math.inf):
                    zbuffer[key] = z
    return zbuffer
