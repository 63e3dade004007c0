// The mapping nodelet's source-view adapter (src/ros/source_views.cpp).
#include <gtest/gtest.h>

#include <cmath>

#include "amhmvs_mapping/ros/source_views.h"

using amhmvs::PinholeCamera;
using amhmvs_mapping::chooseSourceViews;
using amhmvs_mapping::SourceViewOptions;

namespace {

// A 100x100 camera at `center` looking along world +z, rotated by `yaw_deg`
// about the camera's y axis.
PinholeCamera cameraAt(const Eigen::Vector3d& center, double yaw_deg = 0) {
  PinholeCamera camera;
  camera.fx = camera.fy = 100;
  camera.cx = camera.cy = 49.5;
  camera.width = camera.height = 100;
  camera.R = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  camera.t = -camera.R * center;
  return camera;
}

}  // namespace

TEST(SourceViews, MostRecentWithinBaselineAndAngle) {
  std::vector<PinholeCamera> cameras = {
      cameraAt({0.5, 0, 0}),       // 0: ok
      cameraAt({0.3, 0, 0}),       // 1: ok
      cameraAt({0.001, 0, 0}),     // 2: baseline too small
      cameraAt({50, 0, 0}),        // 3: baseline too large
      cameraAt({0.2, 0, 0}, 60),   // 4: axis angle too large
      cameraAt({0.1, 0, 0}, 10),   // 5: ok
  };
  std::vector<const PinholeCamera*> stored;
  for (const auto& camera : cameras) stored.push_back(&camera);
  SourceViewOptions options;
  options.num_sources = 2;
  options.min_baseline = 0.05;
  options.max_baseline = 10;
  options.max_angle_deg = 45;
  ASSERT_EQ(options.validate(), "");
  const PinholeCamera target = cameraAt({0, 0, 0});
  EXPECT_EQ(chooseSourceViews(target, stored, options), (std::vector<size_t>{5, 1}));
  options.num_sources = 8;
  EXPECT_EQ(chooseSourceViews(target, stored, options), (std::vector<size_t>{5, 1, 0}));
  EXPECT_TRUE(chooseSourceViews(target, {}, options).empty());
}

TEST(SourceViews, SkipsInvalidCamerasAndRejectsBadOptions) {
  PinholeCamera bad = cameraAt({0.5, 0, 0});
  bad.t.x() = std::nan("");
  const PinholeCamera good = cameraAt({0.4, 0, 0});
  SourceViewOptions options;
  EXPECT_EQ(chooseSourceViews(cameraAt({0, 0, 0}), {&good, &bad, nullptr}, options),
            (std::vector<size_t>{0}));
  options.max_baseline = 0.01;
  EXPECT_NE(options.validate(), "");
  options = SourceViewOptions();
  options.num_sources = 0;
  EXPECT_NE(options.validate(), "");
}
