// A synthetic textured plane imaged through a distorted lens (each distorted
// pixel's ideal point found by inverting the model exactly), for the tests of
// the core's undistortion (test/unit) and the nodelet's (test/ros).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/image_remap.h"
#include "amhmvs_mapping/mapping/undistortion.h"
#include "test_helpers.h"

namespace amhmvs {
namespace test {

// Intensity of the plane Z = 1 at ideal normalised (x, y): smooth, so that
// bilinear sampling is accurate.
inline double texture(const Eigen::Vector2d& xy) {
  return 128 + 100 * std::sin(9 * xy.x()) * std::cos(7 * xy.y());
}

inline PinholeCamera distortionTestCamera() { return centredCamera(160, 120, 120); }

// Strong distortions of each CameraInfo model (coefficients in D's order).
inline std::vector<double> testCoefficients(const std::string& model) {
  if (model == "rational_polynomial") return {-0.2, 0.05, 0.001, 0.001, 0.0, 0.1, 0.0, 0.0};
  if (model == "equidistant") return {-0.05, 0.01, 0.0, 0.0};
  return {-0.25, 0.08, 0.002, -0.001, 0.0};  // plumb_bob
}

// Ideal normalised point whose distortion is `distorted` (Newton with a
// numeric Jacobian; exact to ~1e-12).
inline Eigen::Vector2d undistortPoint(const Distortion& d, const Eigen::Vector2d& distorted) {
  Eigen::Vector2d ideal = distorted;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2d residual = distortNormalized(d, ideal) - distorted;
    if (residual.norm() < 1e-14) break;
    Eigen::Matrix2d jacobian;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      step[k] = 1e-7;
      jacobian.col(k) = (distortNormalized(d, ideal + step) - distortNormalized(d, ideal - step)) / 2e-7;
    }
    ideal -= jacobian.inverse() * residual;
  }
  return ideal;
}

// The distorted image of the textured plane.
inline ImageU8 distortedImage(const PinholeCamera& c, const Distortion& d) {
  ImageU8 image(c.width, c.height, 1, 0);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u)
      image.at(u, v) = static_cast<uint8_t>(std::lround(
          texture(undistortPoint(d, Eigen::Vector2d((u - c.cx) / c.fx, (v - c.cy) / c.fy)))));
  return image;
}

// The image as the ideal pinhole `camera` (same K and size) would have seen
// it, by the model itself: each output pixel samples the input bilinearly at
// its distorted position (0 outside). The reference the nodelet's OpenCV
// rectification is held to; the product undistorts with image_geometry.
inline ImageU8 undistortImage(const ImageU8& image, const PinholeCamera& camera, const Distortion& distortion) {
  const auto distorted_position = [&](int u, int v, double* su, double* sv) {
    const Eigen::Vector2d ideal((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy);
    const Eigen::Vector2d distorted = distortNormalized(distortion, ideal);
    *su = camera.fx * distorted.x() + camera.cx;
    *sv = camera.fy * distorted.y() + camera.cy;
  };
  return remapBilinear(image, distorted_position, RemapBorder::kZero);
}

// Mean |image - ideal texture| over the output pixels that were filled.
inline double meanError(const ImageU8& image, const PinholeCamera& c, int* filled) {
  double sum = 0;
  *filled = 0;
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) {
      if (image.at(u, v) == 0) continue;
      sum += std::abs(image.at(u, v) - texture(Eigen::Vector2d((u - c.cx) / c.fx, (v - c.cy) / c.fy)));
      ++*filled;
    }
  return sum / std::max(*filled, 1);
}

}  // namespace test
}  // namespace amhmvs
