#include "amhmvs_mapping/core/camera.h"

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

std::string PinholeCamera::validate() const {
  std::ostringstream why;
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0)) {
    why << "focal lengths must be positive and finite (fx=" << fx << ", fy=" << fy << ")";
  } else if (!(std::isfinite(cx) && std::isfinite(cy))) {
    why << "principal point is not finite";
  } else if (width <= 0 || height <= 0) {
    why << "image size must be positive (" << width << "x" << height << ")";
  } else if (cx < 0 || cy < 0 || cx > width || cy > height) {
    // A principal point off the image means the image is not the one the
    // intrinsics were calibrated for (wrong file, or a resized image).
    why << "principal point (" << cx << ", " << cy << ") lies outside the " << width << "x"
        << height << " image: the image does not match its camera";
  } else if (!R.allFinite() || !t.allFinite()) {
    why << "pose contains non-finite values";
  } else {
    // A rotation: orthonormal with determinant +1. The tolerance admits poses
    // printed with 6 significant digits (as in MVSNet cam files).
    const double orthogonality = (R * R.transpose() - Eigen::Matrix3d::Identity()).norm();
    const double det = R.determinant();
    if (orthogonality > 1e-3 || std::abs(det - 1.0) > 1e-3) {
      why << "pose rotation is not rigid (|R R^T - I| = " << orthogonality
          << ", det R = " << det << ")";
    }
  }
  return why.str();
}

RelativePose relativePose(const PinholeCamera& reference, const PinholeCamera& source) {
  RelativePose rel;
  rel.R = source.R * reference.R.transpose();
  rel.t = source.t - rel.R * reference.t;
  return rel;
}

double triangulationAngle(const Eigen::Vector3d& center_a, const Eigen::Vector3d& center_b,
                          const Eigen::Vector3d& point) {
  const Eigen::Vector3d a = (center_a - point).normalized();
  const Eigen::Vector3d b = (center_b - point).normalized();
  return std::acos(std::max(-1.0, std::min(1.0, a.dot(b))));
}

}  // namespace amhmvs
