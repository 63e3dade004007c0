// Small synthetic keyframes for the mapping-core tests.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "test_helpers.h"

namespace amhmvs {
namespace test {

constexpr int kKeyframeWidth = 32, kKeyframeHeight = 24;

// Camera-to-world pose at `position`, turned by `yaw_deg` about the y axis.
inline Eigen::Isometry3d poseAt(const Eigen::Vector3d& position, double yaw_deg = 0) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()).matrix();
  pose.translation() = position;
  return pose;
}

// A 32x24 keyframe (f = 30 px, centred principal point) with a constant image.
inline Keyframe smallKeyframe(int64_t id, double stamp, const Eigen::Isometry3d& camera_to_world,
                              int channels = 1, uint8_t fill = 0) {
  Keyframe keyframe;
  keyframe.id = id;
  keyframe.stamp = stamp;
  keyframe.camera = centredCamera(kKeyframeWidth, kKeyframeHeight, 30);
  keyframe.setCameraToWorld(camera_to_world);
  keyframe.image = ImageU8(kKeyframeWidth, kKeyframeHeight, channels, fill);
  return keyframe;
}

// A wall z = kWallZ (world) facing cameras that look along +z: an injected
// estimator returns its exact depth, so that sources, fusion, the map and
// re-posing can be checked against exact numbers.
constexpr double kWallZ = 5.0;

// Depth and normal of the wall seen by the problem's reference camera.
inline DepthMap wallDepth(const DepthProblem& problem) {
  const PinholeCamera& camera = problem.reference_camera;
  const double depth = kWallZ - cameraToWorld(camera).translation().z();
  DepthMap map;
  map.depth = ImageF(camera.width, camera.height, 1, static_cast<float>(depth));
  map.normal = ImageF(camera.width, camera.height, 3, 0.0f);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) map.normal.at(x, y, 2) = -1.0f;
  map.cost = ImageF(camera.width, camera.height, 1, 0.1f);
  return map;
}

// The wall's exact depth for first estimates; a refinement (two sources) of
// the keyframe at x = 0 is fed bad sources: a wrong depth (4 m) with the high
// cost the estimator gives such matches; other refinements find the wall with
// a lower cost than before.
inline DepthMap wallDepthWithABadRefinementOfKeyframe0(const DepthProblem& problem) {
  DepthMap map = wallDepth(problem);
  if (problem.source_cameras.size() < 2) return map;
  const bool keyframe_0 = std::abs(cameraToWorld(problem.reference_camera).translation().x()) < 1e-9;
  std::fill(map.depth.data.begin(), map.depth.data.end(), keyframe_0 ? 4.0f : map.depth.data[0]);
  std::fill(map.cost.data.begin(), map.cost.data.end(), keyframe_0 ? 0.9f : 0.05f);
  return map;
}

inline OnlineMapperOptions wallOptions() {
  OnlineMapperOptions options;
  options.sources.default_scene_depth = kWallZ;
  options.sources.min_overlap = 0.3;
  options.map.leaf_size = 0.05;
  options.surface.voxel_size = 0.1;  // a 5 m wall seen through 17 cm pixels
  return options;
}

// An RGB keyframe at x metres along the wall (stamp = id).
inline Keyframe keyframeAt(int64_t id, double x) {
  return smallKeyframe(id, static_cast<double>(id), poseAt({x, 0, 0}), 3, 128);
}

}  // namespace test
}  // namespace amhmvs
