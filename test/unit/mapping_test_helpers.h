// Small synthetic keyframes for the mapping-core tests.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/mapping/keyframe_store.h"
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

}  // namespace test
}  // namespace amhmvs
