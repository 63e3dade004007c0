// Where a viewer should look to see what a keyframe saw, and which way is
// up: the point on its optical axis at the median valid depth of its depth
// map, in the world frame, and the world direction to show upwards. The
// mapping nodelet publishes both as a tf frame (~view_frame: its origin at
// the anchor, its z up) for the first keyframe with depth; the rviz config
// uses it as its fixed frame, so that the view follows the data upright
// instead of fixed coordinates with z up.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// False (anchor untouched) when the depth map has no valid pixel
// (finite, > 0).
bool viewAnchor(const PinholeCamera& camera, const ImageF& depth, Eigen::Vector3d* anchor);

// The world's up for a viewer, a unit vector, from `setting`:
//  - "auto": world +z when the camera's up (-y of its optical frame,
//    REP-103) is within kAutoUpMaxTilt of it, as in a REP-103 world (x
//    forward, z up), else the signed world axis nearest to the camera's up
//    (a world that is a camera frame, as a visual odometry's first frame:
//    y down);
//  - "X,Y,Z": that direction (need not be unit).
// Throws InputError for anything else (validateViewUp says why).
Eigen::Vector3d viewUp(const std::string& setting, const Eigen::Matrix3d& camera_to_world_rotation);
constexpr double kAutoUpMaxTiltDeg = 70;
// Empty when `setting` is "auto" or three finite numbers, not all zero.
std::string validateViewUp(const std::string& setting);

// The view frame's orientation in the world: the shortest rotation that
// takes the world's z to `up` (a half turn about x for -z).
Eigen::Quaterniond viewOrientation(const Eigen::Vector3d& up);

}  // namespace amhmvs
