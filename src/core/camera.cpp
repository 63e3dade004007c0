#include "amhmvs_mapping/core/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace amhmvs {

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

PinholeCamera PinholeCamera::resized(int new_width, int new_height) const {
  PinholeCamera out = *this;
  const double sx = static_cast<double>(new_width) / width;
  const double sy = static_cast<double>(new_height) / height;
  out.fx = fx * sx;
  out.fy = fy * sy;
  out.cx = (cx + 0.5) * sx - 0.5;
  out.cy = (cy + 0.5) * sy - 0.5;
  out.width = new_width;
  out.height = new_height;
  return out;
}

namespace {

enum class CameraProblem { kNone, kFocalLengths, kPrincipalPoint, kSize, kPrincipalPointOutside, kPose, kRotation };

double orthogonalityOf(const Eigen::Matrix3d& R) { return (R * R.transpose() - Eigen::Matrix3d::Identity()).norm(); }

CameraProblem firstProblem(const PinholeCamera& c) {
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && c.fx > 0 && c.fy > 0)) return CameraProblem::kFocalLengths;
  if (!(std::isfinite(c.cx) && std::isfinite(c.cy))) return CameraProblem::kPrincipalPoint;
  if (c.width <= 0 || c.height <= 0) return CameraProblem::kSize;
  if (c.cx < 0 || c.cy < 0 || c.cx > c.width || c.cy > c.height) return CameraProblem::kPrincipalPointOutside;
  if (!c.R.allFinite() || !c.t.allFinite()) return CameraProblem::kPose;
  // A rotation: orthonormal with determinant +1. The tolerance admits poses
  // printed with 6 significant digits (as in MVSNet cam files).
  if (orthogonalityOf(c.R) > 1e-3 || std::abs(c.R.determinant() - 1.0) > 1e-3) return CameraProblem::kRotation;
  return CameraProblem::kNone;
}

}  // namespace

// The checks first, the message only for a problem: source selection asks
// every candidate of a large store.
std::string PinholeCamera::validate() const {
  const CameraProblem problem = firstProblem(*this);
  if (problem == CameraProblem::kNone) return {};
  std::ostringstream why;
  switch (problem) {
    case CameraProblem::kFocalLengths:
      why << "focal lengths must be positive and finite (fx=" << fx << ", fy=" << fy << ")";
      break;
    case CameraProblem::kPrincipalPoint: why << "principal point is not finite"; break;
    case CameraProblem::kSize: why << "image size must be positive (" << width << "x" << height << ")"; break;
    case CameraProblem::kPrincipalPointOutside:
      // A principal point off the image means the image is not the one the
      // intrinsics were calibrated for (wrong file, or a resized image).
      why << "principal point (" << cx << ", " << cy << ") lies outside the " << width << "x" << height
          << " image: the image does not match its camera";
      break;
    case CameraProblem::kPose: why << "pose contains non-finite values"; break;
    case CameraProblem::kRotation:
      why << "pose rotation is not rigid (|R R^T - I| = " << orthogonalityOf(R) << ", det R = " << R.determinant()
          << ")";
      break;
    case CameraProblem::kNone: break;
  }
  return why.str();
}

std::string conditioningProblem(const PinholeCamera& camera, double depth_min, double depth_max) {
  std::ostringstream why;
  why.precision(3);
  const double side = std::max(camera.width, camera.height);
  const double focal_ratio = std::min(camera.fx, camera.fy) / side;
  const double focal_ratio_max = std::max(camera.fx, camera.fy) / side;
  // Focal length in units of the longest image side. Below 1e-3 the field of
  // view exceeds 179.9 deg: the rays of the border pixels are within 1e-3 rad
  // of the image plane, and the float plane-induced homography (entries
  // ~ f^-1 against ~ 1) loses all its digits. Above 1e4 the whole image spans
  // less than 1e-4 rad: neighbouring pixel rays differ by < 1e-4 / side rad,
  // below float resolution (2^-24 ~ 6e-8) relative to the ray for sides over
  // ~1600 px, so depth from parallax is noise.
  if (!(focal_ratio >= kMinFocalPerImageSide && focal_ratio_max <= kMaxFocalPerImageSide)) {
    why << "focal length (fx=" << camera.fx << ", fy=" << camera.fy << ") is outside "
        << kMinFocalPerImageSide << ".." << kMaxFocalPerImageSide << " times the longest image side ("
        << side << " px)";
    return why.str();
  }
  // The estimator works in float with depths, inverse depths and products of
  // up to three of them (plane distances times ray terms): within
  // [1e-12, 1e12] their cubes stay normal floats (1e-36 > FLT_MIN = 1.2e-38,
  // 1e36 < FLT_MAX = 3.4e38); a range 1e-300..1e300 became 0..inf in float.
  if (!(depth_min >= kMinDepth && depth_max <= kMaxDepth && depth_max > depth_min)) {
    why << "depth range [" << depth_min << ", " << depth_max << "] is outside " << kMinDepth
        << ".." << kMaxDepth << " (float range of the estimator) or empty";
    return why.str();
  }
  // World points (fusion, map, point cloud files) are floats: a point near
  // this camera has magnitude ~ |C| and a rounding error of |C| 2^-24. With
  // |C| <= 1e4 depth_max that error is <= 6e-4 depth_max, i.e. well under 1 %
  // of any depth in a range of ratio up to 10; a centre 1e308 away (finite,
  // valid rotation) left nothing but NaN.
  const double centre_distance = camera.center().stableNorm();  // no overflow at 1e308
  if (!(centre_distance <= kMaxCentreDistancePerDepth * depth_max)) {
    why << "camera centre is " << centre_distance << " from the world origin, more than "
        << kMaxCentreDistancePerDepth << " times depth_max (" << depth_max
        << "): world points would lose their precision in float";
  }
  return why.str();
}

RelativePose relativePose(const PinholeCamera& reference, const PinholeCamera& source) {
  RelativePose rel;
  rel.R = source.R * reference.R.transpose();
  rel.t = source.t - rel.R * reference.t;
  return rel;
}

Eigen::Vector3d cameraAngularVelocity(const PinholeCamera& earlier, const PinholeCamera& later, double seconds) {
  // Camera-to-world rotations are the transposes of PinholeCamera::R.
  return cameraAngularVelocity(Eigen::Matrix3d(earlier.R.transpose()), Eigen::Matrix3d(later.R.transpose()), seconds);
}

Eigen::Vector3d cameraAngularVelocity(const Eigen::Matrix3d& earlier_to_world, const Eigen::Matrix3d& later_to_world,
                                      double seconds) {
  // R_prev^T R: the turn in the camera's own frame.
  const Eigen::AngleAxisd turn(Eigen::Matrix3d(earlier_to_world.transpose() * later_to_world));
  return turn.angle() * turn.axis() / seconds;
}

double triangulationAngle(const Eigen::Vector3d& center_a, const Eigen::Vector3d& center_b,
                          const Eigen::Vector3d& point) {
  const Eigen::Vector3d a = (center_a - point).normalized();
  const Eigen::Vector3d b = (center_b - point).normalized();
  return std::acos(std::max(-1.0, std::min(1.0, a.dot(b))));
}

Eigen::Isometry3d cameraToWorld(const PinholeCamera& camera) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = camera.R.transpose();
  pose.translation() = -camera.R.transpose() * camera.t;
  return pose;
}

void setCameraToWorld(const Eigen::Isometry3d& camera_to_world, PinholeCamera* camera) {
  camera->R = camera_to_world.linear().transpose();
  camera->t = -camera->R * camera_to_world.translation();
}

}  // namespace amhmvs
