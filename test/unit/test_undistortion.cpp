// Undistortion (undistortion.h): a synthetic textured plane imaged through a
// distorted lens (each distorted pixel's ideal point found by inverting the
// model exactly) must come back as the ideal pinhole image.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "amhmvs_mapping/mapping/undistortion.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// Intensity of the plane Z = 1 at ideal normalised (x, y): smooth, so that
// bilinear sampling is accurate.
double texture(const Eigen::Vector2d& xy) {
  return 128 + 100 * std::sin(9 * xy.x()) * std::cos(7 * xy.y());
}

PinholeCamera camera() {
  PinholeCamera c = test::centredCamera(160, 120, 120);
  return c;
}

// Ideal normalised point whose distortion is `distorted` (Newton with a
// numeric Jacobian; exact to ~1e-12).
Eigen::Vector2d undistortPoint(const Distortion& d, const Eigen::Vector2d& distorted) {
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
ImageU8 distortedImage(const PinholeCamera& c, const Distortion& d) {
  ImageU8 image(c.width, c.height, 1, 0);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u)
      image.at(u, v) = static_cast<uint8_t>(std::lround(
          texture(undistortPoint(d, Eigen::Vector2d((u - c.cx) / c.fx, (v - c.cy) / c.fy)))));
  return image;
}

// Mean |image - ideal texture| over the output pixels that were filled.
double meanError(const ImageU8& image, const PinholeCamera& c, int* filled) {
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

void expectUndistorted(const std::string& model, const std::vector<double>& coefficients) {
  SCOPED_TRACE(model);
  Distortion d;
  ASSERT_EQ(parseDistortion(model, coefficients, &d), "");
  ASSERT_FALSE(d.isZero());
  const PinholeCamera c = camera();
  const ImageU8 distorted = distortedImage(c, d);
  int filled = 0;
  const double before = meanError(distorted, c, &filled);
  const double after = meanError(undistortImage(distorted, c, d), c, &filled);
  std::printf("%s: mean error %.2f grey levels distorted, %.2f undistorted (%d pixels)\n", model.c_str(), before,
              after, filled);
  EXPECT_GT(filled, c.width * c.height * 8 / 10);
  EXPECT_LT(after, 1.5) << "grey levels";   // bilinear resampling + rounding
  EXPECT_GT(before, 10 * after);            // the distortion is strong enough to matter
}

TEST(Undistortion, PlumbBobImageMatchesTheIdealPinhole) {
  expectUndistorted("plumb_bob", {-0.25, 0.08, 0.002, -0.001, 0.0});
}

TEST(Undistortion, RationalPolynomialImageMatchesTheIdealPinhole) {
  expectUndistorted("rational_polynomial", {-0.2, 0.05, 0.001, 0.001, 0.0, 0.1, 0.0, 0.0});
}

TEST(Undistortion, EquidistantImageMatchesTheIdealPinhole) {
  expectUndistorted("equidistant", {-0.05, 0.01, 0.0, 0.0});
}

TEST(Undistortion, ModelsAgainstClosedForms) {
  Distortion d;
  ASSERT_EQ(parseDistortion("plumb_bob", {0.1}, &d), "");
  const Eigen::Vector2d p(0.3, -0.2);
  const double r2 = p.squaredNorm();
  EXPECT_TRUE(distortNormalized(d, p).isApprox(p * (1 + 0.1 * r2), 1e-15));
  ASSERT_EQ(parseDistortion("equidistant", {}, &d), "");
  const double r = std::sqrt(r2);
  EXPECT_TRUE(distortNormalized(d, p).isApprox(p * (std::atan(r) / r), 1e-15));  // pure fisheye
  ASSERT_EQ(parseDistortion("", {0, 0, 0, 0, 0}, &d), "");
  EXPECT_TRUE(d.isZero());
  EXPECT_NE(parseDistortion("kannala", {}, &d), "");
  EXPECT_NE(parseDistortion("equidistant", {0, 0, 0, 0, 0}, &d), "");
  EXPECT_NE(parseDistortion("plumb_bob", {NAN}, &d), "");
}

}  // namespace
}  // namespace amhmvs
