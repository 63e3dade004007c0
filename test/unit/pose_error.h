// A tracker's pose error put into a camera, and how far apart two cameras of
// one view see a surface: the error it causes in stereo (tests of the pose
// refinement).
#pragma once

#include <cmath>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {
namespace test {

// Moves a camera's centre by `shift` (world) and turns it by `angle_deg`
// about `axis` (camera frame, about its centre).
inline PinholeCamera withPoseError(const PinholeCamera& camera, const Eigen::Vector3d& shift,
                                   const Eigen::Vector3d& axis, double angle_deg) {
  Eigen::Isometry3d pose = cameraToWorld(camera);
  pose.linear() = pose.linear() * Eigen::AngleAxisd(angle_deg * M_PI / 180, axis.normalized()).matrix();
  pose.translation() += shift;
  PinholeCamera moved = camera;
  setCameraToWorld(pose, &moved);
  return moved;
}

// Calls f(world point) for every 8th pixel of `depth` (the z-depth of the
// view `viewer`) that has a depth; returns how many.
template <typename PerPoint>
int forSurfacePoints(const PinholeCamera& viewer, const ImageF& depth, PerPoint f) {
  const Eigen::Isometry3d viewer_to_world = cameraToWorld(viewer);
  int count = 0;
  for (int y = 0; y < viewer.height; y += 8) {
    for (int x = 0; x < viewer.width; x += 8) {
      if (!std::isfinite(depth.at(x, y))) continue;
      f(Eigen::Vector3d(viewer_to_world * viewer.backproject(x, y, depth.at(x, y))));
      ++count;
    }
  }
  return count;
}

// Mean distance in pixels between where cameras `a` and `b` see the surface
// of `depth`, the z-depth of the view `viewer` (every 8th pixel).
inline double meanImageMotionPx(const PinholeCamera& viewer, const ImageF& depth, const PinholeCamera& a,
                                const PinholeCamera& b) {
  double sum = 0;
  const int count = forSurfacePoints(viewer, depth, [&](const Eigen::Vector3d& world) {
    sum += (a.project(a.toCamera(world)) - b.project(b.toCamera(world))).norm();
  });
  return count > 0 ? sum / count : NAN;
}

// The same, only the part across the epipolar lines of `b` (its lines of the
// view `viewer`): what stereo between the two cannot absorb in depth.
inline double meanAcrossEpipolarPx(const PinholeCamera& viewer, const ImageF& depth, const PinholeCamera& a,
                                   const PinholeCamera& b) {
  const Eigen::Vector2d epipole = b.project(b.toCamera(viewer.center()));
  double sum = 0;
  const int count = forSurfacePoints(viewer, depth, [&](const Eigen::Vector3d& world) {
    const Eigen::Vector2d seen = b.project(b.toCamera(world));
    const Eigen::Vector2d along = (seen - epipole).normalized();
    sum += std::abs((a.project(a.toCamera(world)) - seen).dot(Eigen::Vector2d(-along.y(), along.x())));
  });
  return count > 0 ? sum / count : NAN;
}

}  // namespace test
}  // namespace amhmvs
