// One surface point of a keyframe, in that keyframe's camera frame: what
// fusion emits, the keyframe store keeps and the voxel map averages (one type
// from fusion to the map; the map exports an io PointCloud).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace amhmvs {

struct KeyframePoint {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit, or zero when unknown
  uint8_t rgb[3] = {0, 0, 0};
  // >= 0. From fusion: agreeing sources / sources in which the point projected
  // in front and inside the image onto a pixel not fused before, in (0, 1]
  // (with min_consistent_views 0 it can be 0).
  float confidence = 1.0f;
  uint16_t consistent_views = 0;  // fusion: agreeing sources (the reference not counted)
};
using KeyframePoints = std::vector<KeyframePoint>;

}  // namespace amhmvs
