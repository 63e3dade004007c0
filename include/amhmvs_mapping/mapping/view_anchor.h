// Where a viewer should look to see what a keyframe saw: the point on its
// optical axis at the median valid depth of its depth map, in the world
// frame. The mapping nodelet publishes it as a tf frame (~view_frame) for
// the first keyframe with depth, so that rviz's view follows the data
// instead of fixed coordinates.
#pragma once

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// False (anchor untouched) when the depth map has no valid pixel
// (finite, > 0).
bool viewAnchor(const PinholeCamera& camera, const ImageF& depth, Eigen::Vector3d* anchor);

}  // namespace amhmvs
