// Lens undistortion of keyframe images (ROS CameraInfo models): the image is
// resampled to the ideal pinhole camera with the same K, so that the depth
// estimator, which assumes a pinhole, sees straight lines straight.
//
// Models (coefficients as in sensor_msgs/CameraInfo D, OpenCV's conventions;
// x, y = X/Z, Y/Z ideal normalised coordinates, r^2 = x^2 + y^2):
//   plumb_bob (5: k1 k2 p1 p2 k3) and rational_polynomial (8: k1 k2 p1 p2 k3
//   k4 k5 k6): radial (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 +
//   k6 r^6) times (x, y), plus tangential (2 p1 x y + p2 (r^2 + 2 x^2),
//   p1 (r^2 + 2 y^2) + 2 p2 x y);
//   equidistant (4: k1 k2 k3 k4; fisheye): theta = atan(r), theta_d =
//   theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8), distorted
//   = (theta_d / r) (x, y).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

enum class DistortionModel { kPlumbBob, kRationalPolynomial, kEquidistant };

struct Distortion {
  DistortionModel model = DistortionModel::kPlumbBob;
  std::vector<double> coefficients;  // see the file comment; parseDistortion pads them with 0s to the model's count

  // True when every coefficient is 0 (nothing to undistort).
  bool isZero() const;
};

// Parses a CameraInfo distortion_model name and D. An empty name with an
// all-zero D is plumb_bob. Returns why not when the model is unknown, D is
// longer than the model has coefficients, or a coefficient is not finite.
std::string parseDistortion(const std::string& model, const std::vector<double>& d, Distortion* distortion);

// Distorted normalised coordinates of ideal normalised coordinates.
Eigen::Vector2d distortNormalized(const Distortion& distortion, const Eigen::Vector2d& ideal);

// The image as the ideal pinhole `camera` (same K and size) would have seen
// it: each output pixel samples the input bilinearly at its distorted
// position; pixels whose position falls outside the input are 0.
ImageU8 undistortImage(const ImageU8& image, const PinholeCamera& camera, const Distortion& distortion);

}  // namespace amhmvs
