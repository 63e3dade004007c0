// view_anchor.h: the point a viewer looks at, on the keyframe's optical axis
// at its depth map's median depth, in the world frame, and the world's up.
#include "amhmvs_mapping/mapping/view_anchor.h"

#include <gtest/gtest.h>

#include <limits>

#include "amhmvs_mapping/core/error.h"

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

// A camera's rotation (camera-to-world) from its optical axes in the world.
Eigen::Matrix3d opticalAxes(const Eigen::Vector3d& right, const Eigen::Vector3d& down, const Eigen::Vector3d& forward) {
  Eigen::Matrix3d rotation;
  rotation << right, down, forward;
  return rotation;
}

TEST(ViewUp, AutoKeepsZInARep103WorldEvenWhenTheCameraLooksSteeplyDown) {
  // REP-103 world (x forward, z up); the camera looks along x, then 60 deg down.
  const Eigen::Matrix3d level = opticalAxes({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  EXPECT_EQ(viewUp("auto", level), Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d down60 = Eigen::AngleAxisd(60 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() * level;
  ASSERT_NEAR((down60 * Eigen::Vector3d::UnitZ()).z(), -std::sin(60 * M_PI / 180), 1e-12);  // it looks down
  EXPECT_EQ(viewUp("auto", down60), Eigen::Vector3d::UnitZ());
}

TEST(ViewUp, AutoTakesTheNearestAxisInAWorldThatIsACameraFrame) {
  // A world that is the first camera's frame (y down, as 7-Scenes): -y is up,
  // also when the camera has since pitched 30 deg or turned about the vertical.
  EXPECT_EQ(viewUp("auto", Eigen::Matrix3d::Identity()), -Eigen::Vector3d::UnitY());
  const Eigen::Matrix3d pitched = Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_EQ(viewUp("auto", pitched), -Eigen::Vector3d::UnitY());
  const Eigen::Matrix3d turned = Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_EQ(viewUp("auto", turned), -Eigen::Vector3d::UnitY());
  // An x-up world.
  EXPECT_EQ(viewUp("auto", opticalAxes({0, 1, 0}, {-1, 0, 0}, {0, 0, 1})), Eigen::Vector3d::UnitX());
}

TEST(ViewUp, AGivenDirectionIsNormalisedAndNonsenseIsRefusedWithTheSetting) {
  EXPECT_TRUE((viewUp(" 0, -2, 0 ", Eigen::Matrix3d::Identity()) - Eigen::Vector3d(0, -1, 0)).norm() < 1e-12);
  EXPECT_EQ(validateViewUp("auto"), "");
  EXPECT_EQ(validateViewUp("1,0,0"), "");
  for (const std::string bad : {"", "up", "0,0,0", "1,2", "1,2,3,4", "1,nan,0", "1,x,0"}) {
    EXPECT_NE(validateViewUp(bad).find("'" + bad + "'"), std::string::npos) << bad;
    EXPECT_THROW(viewUp(bad, Eigen::Matrix3d::Identity()), InputError) << bad;
  }
}

TEST(ViewUp, TheViewFramesZIsUp) {
  for (const Eigen::Vector3d up : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, -1, 0),
                                   Eigen::Vector3d(1, 2, -3).normalized()}) {
    const Eigen::Quaterniond orientation = viewOrientation(up);
    EXPECT_NEAR(orientation.norm(), 1, 1e-12);
    EXPECT_LT((orientation * Eigen::Vector3d::UnitZ() - up).norm(), 1e-12) << up.transpose();
  }
}

}  // namespace
}  // namespace amhmvs
