// The nodelet's undistortion (ros/image_rectifier.h: image_geometry +
// OpenCV's maps) on the textured plane of test/unit/distorted_plane.h: as
// accurate as the core's own resampling (mapping/undistortion.h) for every
// CameraInfo model, and bad models refused.
#include <gtest/gtest.h>

#include <cstdio>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/ros/image_rectifier.h"
#include "distorted_plane.h"

using namespace amhmvs_mapping;

namespace {

sensor_msgs::CameraInfo cameraInfo(const amhmvs::PinholeCamera& c, const std::string& model,
                                   const std::vector<double>& d) {
  sensor_msgs::CameraInfo info;
  info.width = c.width;
  info.height = c.height;
  info.distortion_model = model;
  info.D = d;
  info.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  info.P = {c.fx * 0.8, 0, c.cx + 5, 0, 0, c.fy * 0.8, c.cy, 0, 0, 0, 1, 0};  // ignored: output is K
  return info;
}

void expectAsAccurateAsTheCore(const std::string& model) {
  SCOPED_TRACE(model);
  amhmvs::Distortion d;
  ASSERT_EQ(amhmvs::parseDistortion(model, amhmvs::test::testCoefficients(model), &d), "");
  const amhmvs::PinholeCamera c = amhmvs::test::distortionTestCamera();
  const amhmvs::ImageU8 distorted = amhmvs::test::distortedImage(c, d);
  int core_filled = 0, filled = 0;
  const double core_error = amhmvs::test::meanError(amhmvs::test::undistortImage(distorted, c, d), c, &core_filled);
  amhmvs::ImageU8 image = distorted;
  ImageRectifier rectifier;
  rectifier.undistort(cameraInfo(c, model, d.coefficients), &image);
  const double error = amhmvs::test::meanError(image, c, &filled);
  std::printf("%s: mean error %.3f grey levels over %d pixels (core: %.3f over %d)\n", model.c_str(), error, filled,
              core_error, core_filled);
  EXPECT_GE(filled, core_filled);
  EXPECT_LT(error, 1.5) << "grey levels";  // the core test's bound: bilinear resampling + rounding
  // OpenCV interpolates at 1/32 px (measured: +0.003 grey levels against the core).
  EXPECT_LE(error, core_error + 0.01) << "not worse than the core's resampling";
}

}  // namespace

TEST(ImageRectifier, PlumbBobAsAccurateAsTheCore) { expectAsAccurateAsTheCore("plumb_bob"); }
TEST(ImageRectifier, RationalPolynomialAsAccurateAsTheCore) { expectAsAccurateAsTheCore("rational_polynomial"); }
TEST(ImageRectifier, EquidistantAsAccurateAsTheCore) { expectAsAccurateAsTheCore("equidistant"); }

TEST(ImageRectifier, LeavesUndistortedImagesAndRefusesBadModels) {
  const amhmvs::PinholeCamera c = amhmvs::test::distortionTestCamera();
  amhmvs::ImageU8 image(c.width, c.height, 3, 7);
  const amhmvs::ImageU8 original = image;
  ImageRectifier rectifier;
  rectifier.undistort(cameraInfo(c, "plumb_bob", {0, 0, 0, 0, 0}), &image);
  EXPECT_EQ(image.data, original.data);
  EXPECT_THROW(rectifier.undistort(cameraInfo(c, "kannala", {0.1}), &image), amhmvs::InputError);
  EXPECT_THROW(rectifier.undistort(cameraInfo(c, "equidistant", {0.1, 0, 0, 0, 0}), &image), amhmvs::InputError);
  EXPECT_THROW(rectifier.undistort(cameraInfo(c, "plumb_bob", {NAN}), &image), amhmvs::InputError);
}
