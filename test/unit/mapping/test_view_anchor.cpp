// viewAnchor (view_anchor.h): the point a viewer looks at, on the keyframe's
// optical axis at its depth map's median depth, in the world frame.
#include "amhmvs_mapping/mapping/view_anchor.h"

#include <gtest/gtest.h>

#include <limits>

#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

TEST(ViewAnchor, OnTheOpticalAxisAtTheMedianDepthInTheWorldFrame) {
  // A camera at (1, 2, 3) turned 90 degrees about y: its optical axis is +x.
  const Keyframe keyframe = test::smallKeyframe(0, 0, test::poseAt({1, 2, 3}, 90));
  ImageF depth(test::kKeyframeWidth, test::kKeyframeHeight, 1, 2.5f);
  // Outliers and invalid pixels do not move the median.
  for (int x = 0; x < 5; ++x) depth.at(x, 0) = 0.1f;
  depth.at(0, 1) = std::numeric_limits<float>::quiet_NaN();
  depth.at(1, 1) = -1.0f;
  Eigen::Vector3d anchor;
  ASSERT_TRUE(viewAnchor(keyframe.camera, depth, &anchor));
  EXPECT_NEAR(anchor.x(), 1 + 2.5, 1e-9);
  EXPECT_NEAR(anchor.y(), 2, 1e-9);
  EXPECT_NEAR(anchor.z(), 3, 1e-9);
}

TEST(ViewAnchor, NoValidDepthGivesNoAnchor) {
  const Keyframe keyframe = test::smallKeyframe(0, 0, test::poseAt({0, 0, 0}));
  const ImageF depth(test::kKeyframeWidth, test::kKeyframeHeight, 1, std::numeric_limits<float>::quiet_NaN());
  Eigen::Vector3d anchor(7, 7, 7);
  EXPECT_FALSE(viewAnchor(keyframe.camera, depth, &anchor));
  EXPECT_EQ(anchor, Eigen::Vector3d(7, 7, 7));
}

}  // namespace
}  // namespace amhmvs
