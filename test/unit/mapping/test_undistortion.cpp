// The lens models (undistortion.h): a synthetic textured plane imaged through a
// distorted lens (distorted_plane.h) comes back as the ideal pinhole image when
// resampled with the model, and the models' coefficients are checked.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "amhmvs_mapping/mapping/undistortion.h"
#include "distorted_plane.h"

namespace amhmvs {
namespace {

using test::distortedImage;
using test::meanError;

void expectUndistorted(const std::string& model) {
  SCOPED_TRACE(model);
  Distortion d;
  ASSERT_EQ(parseDistortion(model, test::testCoefficients(model), &d), "");
  ASSERT_FALSE(d.isZero());
  const PinholeCamera c = test::distortionTestCamera();
  const ImageU8 distorted = distortedImage(c, d);
  int filled = 0;
  const double before = meanError(distorted, c, &filled);
  const double after = meanError(test::undistortImage(distorted, c, d), c, &filled);
  std::printf("%s: mean error %.2f grey levels distorted, %.2f undistorted (%d pixels)\n", model.c_str(), before,
              after, filled);
  EXPECT_GT(filled, c.width * c.height * 8 / 10);
  EXPECT_LT(after, 1.5) << "grey levels";   // bilinear resampling + rounding
  EXPECT_GT(before, 10 * after);            // the distortion is strong enough to matter
}

TEST(Undistortion, PlumbBobImageMatchesTheIdealPinhole) {
  expectUndistorted("plumb_bob");
}

TEST(Undistortion, RationalPolynomialImageMatchesTheIdealPinhole) {
  expectUndistorted("rational_polynomial");
}

TEST(Undistortion, EquidistantImageMatchesTheIdealPinhole) {
  expectUndistorted("equidistant");
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
