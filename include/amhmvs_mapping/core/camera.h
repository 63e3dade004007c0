// Pinhole camera: intrinsics, image size and world-to-camera pose.
//
// Conventions (REP-103 optical frame): x right, y down, z forward; pixel
// centres at integer coordinates, so the top-left pixel's centre is (0, 0).
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

namespace amhmvs {

// The angle of a rotation, in degrees.
inline double rotationAngleDeg(const Eigen::Matrix3d& rotation) {
  return Eigen::AngleAxisd(rotation).angle() * 180.0 / M_PI;
}

struct PinholeCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  // World-to-camera: X_cam = R * X_world + t.
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Matrix3d K() const;
  Eigen::Vector3d center() const { return -R.transpose() * t; }
  // Camera-to-world rotation's third column: the optical axis in the world.
  Eigen::Vector3d viewingDirection() const { return R.row(2).transpose(); }
  Eigen::Vector3d toCamera(const Eigen::Vector3d& world) const { return R * world + t; }
  Eigen::Vector2d project(const Eigen::Vector3d& camera_point) const {
    return {fx * camera_point.x() / camera_point.z() + cx,
            fy * camera_point.y() / camera_point.z() + cy};
  }
  // Point at z-depth `depth` on the ray through pixel (u, v), camera frame.
  Eigen::Vector3d backproject(double u, double v, double depth) const {
    return {(u - cx) / fx * depth, (v - cy) / fy * depth, depth};
  }
  bool contains(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < width - 0.5 &&
           pixel.y() < height - 0.5;
  }

  // The camera of the same view resampled to (new_width, new_height), with K
  // scaled about pixel centres: f' = f s, c' = (c + 0.5) s - 0.5.
  PinholeCamera resized(int new_width, int new_height) const;

  // Empty string when the camera is usable; otherwise what is wrong with it
  // (non-positive or non-finite focal length, non-finite or non-rigid pose,
  // bad image size).
  std::string validate() const;
};

// Conditioning of a view for the float estimator, fusion and map: empty when
// the camera and its depth range lie within the limits below, otherwise which
// limit is broken, with the values. A camera can pass validate() and still
// give nothing but NaN (focal 1e-300, a centre 1e308 away): these views are
// refused at load. The limits are justified in camera.cpp.
std::string conditioningProblem(const PinholeCamera& camera, double depth_min, double depth_max);
constexpr double kMinFocalPerImageSide = 1e-3;  // f / longest side: field of view < 179.9 deg
constexpr double kMaxFocalPerImageSide = 1e4;   // field of view > 0.006 deg
constexpr double kMinDepth = 1e-12;             // depths, their squares and inverses...
constexpr double kMaxDepth = 1e12;              // ...stay normal floats
constexpr double kMaxCentreDistancePerDepth = 1e4;  // |camera centre| / depth_max

// Relative pose that maps reference-camera points into the source camera:
// X_src = R_rel * X_ref + t_rel.
struct RelativePose {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};
RelativePose relativePose(const PinholeCamera& reference, const PinholeCamera& source);

// The mean angular velocity in the later camera's frame (rad/s) of a camera
// that moved from `earlier` to `later` in `seconds` (> 0).
Eigen::Vector3d cameraAngularVelocity(const PinholeCamera& earlier, const PinholeCamera& later, double seconds);
// The same from the cameras' camera-to-world rotations.
Eigen::Vector3d cameraAngularVelocity(const Eigen::Matrix3d& earlier_to_world, const Eigen::Matrix3d& later_to_world,
                                      double seconds);

// Angle in radians between the rays from two camera centres to a world point.
double triangulationAngle(const Eigen::Vector3d& center_a, const Eigen::Vector3d& center_b,
                          const Eigen::Vector3d& point);

// Camera-to-world pose of a camera (PinholeCamera stores world-to-camera).
Eigen::Isometry3d cameraToWorld(const PinholeCamera& camera);
// Sets the camera's world-to-camera R, t from a camera-to-world pose.
void setCameraToWorld(const Eigen::Isometry3d& camera_to_world, PinholeCamera* camera);

}  // namespace amhmvs
