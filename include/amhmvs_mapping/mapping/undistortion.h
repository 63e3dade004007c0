// The lens distortion models of ROS CameraInfo: D checked against its model
// (the nodelet refuses what it cannot undistort) and the model's mapping of
// ideal to distorted points. The nodelet resamples keyframe images with
// image_geometry (ros/image_rectifier.h); the tests hold it to this model.
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

}  // namespace amhmvs
