// Ground truth in the processed colour camera: reading depth files with
// their units and invalid values, nearest resampling, the z-buffered forward
// warp from a depth camera of its own, and the accuracy / completeness split.
#include <gtest/gtest.h>

#include <cmath>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/depth_metrics.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "mapping_test_helpers.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// Depth at column x of the plane z = 2 + 0.1 X seen by a camera at the
// origin: the ray (u, v, 1) d hits it at d = 2 / (1 - 0.1 u).
float planeDepth(const PinholeCamera& camera, int x) {
  const double u = (x - camera.cx) / camera.fx;
  return static_cast<float>(2.0 / (1.0 - 0.1 * u));
}

TEST(GroundTruthDepth, ReadsSixteenBitDepthWithUnitAndInvalidValues) {
  test::TempDir dir;
  std::string pgm = "P5\n3 1\n65535\n";
  for (int value : {0, 1500, 65535}) {
    pgm += static_cast<char>(value >> 8);
    pgm += static_cast<char>(value & 0xFF);
  }
  GroundTruthDepthSource source;
  source.path = dir.write("d.depth.png", pgm);  // the 16-bit reader goes by content
  source.metres_per_unit = 0.001;
  source.invalid_value = 65535;
  source.registered = false;
  source.depth_camera = test::centredCamera(3, 1, 5);
  const DepthMapView view = readGroundTruthDepth(source, test::centredCamera(6, 2, 10));
  EXPECT_EQ(view.camera.width, 3);  // the depth camera's own
  ASSERT_EQ(view.depth.data.size(), 3u);
  EXPECT_TRUE(std::isnan(view.depth.data[0]));
  EXPECT_FLOAT_EQ(view.depth.data[1], 1.5f);
  EXPECT_TRUE(std::isnan(view.depth.data[2]));

  source.path = dir.write("bad.png", "P6\n1 1\n255\nabc");
  EXPECT_INPUT_ERROR(readGroundTruthDepth(source, source.depth_camera), "bad.png", "16-bit");
}

TEST(GroundTruthDepth, RegisteredPfmIsResampledToTheProcessedSize) {
  test::TempDir dir;
  ImageF truth(4, 2, 1, NAN);
  for (int x = 0; x < 4; ++x) truth.at(x, 0) = truth.at(x, 1) = 1.0f + x;
  truth.at(3, 1) = -1;  // not a depth
  GroundTruthDepthSource source;
  source.path = dir.file("t.pfm");
  writePfm(source.path, truth);
  const ImageF half = groundTruthDepthIn(source, test::centredCamera(2, 1, 10));
  ASSERT_EQ(half.width, 2);
  ASSERT_EQ(half.height, 1);
  EXPECT_FLOAT_EQ(half.at(0, 0), 2.0f);  // pixel centre 0.5 scales to source (1, 1)
  EXPECT_TRUE(std::isnan(half.at(1, 0)));  // source (3, 1): -1 is no depth
}

TEST(GroundTruthDepth, ReprojectsADepthCameraIntoAnOffsetColourCamera) {
  // Depth camera 80x60, f 60 at the origin; colour camera 40x30 with f 28
  // (a wider view), cx 19, centre moved by (-0.01, 0, 0), same orientation.
  PinholeCamera depth_camera = test::centredCamera(80, 60, 60);
  ImageF depth(80, 60);
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) depth.at(x, y) = planeDepth(depth_camera, x);
  }
  depth.at(40, 30) = NAN;  // a hole in the raw depth
  PinholeCamera color = test::centredCamera(40, 30, 28);
  color.cx = 19;
  Eigen::Isometry3d color_to_world = Eigen::Isometry3d::Identity();
  color_to_world.translation() = Eigen::Vector3d(-0.01, 0, 0);
  setCameraToWorld(color_to_world, &color);

  const ImageF warped = reprojectDepth({depth_camera, depth}, color);
  ASSERT_EQ(warped.width, 40);
  long covered = 0;
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      const float d = warped.at(x, y);
      if (std::isnan(d)) continue;
      ++covered;
      // The plane in the colour frame: z_c = 1.999 + 0.1 X_c. A splat lands
      // within half a pixel of its projection: 0.5 / 28 in u moves z by < 0.004.
      const double u = (x - color.cx) / color.fx;
      EXPECT_NEAR(d, 1.999 / (1.0 - 0.1 * u), 0.004) << x << "," << y;
    }
  }
  // The wider colour view leaves a border (about 13 % of the pixels).
  EXPECT_GT(covered, 0.8 * 40 * 30);
  EXPECT_LT(covered, 40 * 30);
}

TEST(GroundTruthDepth, ComparisonSplitsAccuracyAndCompleteness) {
  ImageF truth(4, 1, 1, 2.0f);
  truth.at(3, 0) = NAN;  // no ground truth: not counted
  ImageF estimate(4, 1, 1, NAN);
  estimate.at(0, 0) = 2.01f;  // 0.5 %
  estimate.at(1, 0) = 2.15f;  // 7.5 %
  estimate.at(3, 0) = 5.0f;   // no truth there
  const DepthComparison c = compareDepth(estimate, truth);
  EXPECT_EQ(c.truth_pixels, 3);
  EXPECT_EQ(c.accuracy.total, 2);
  EXPECT_NEAR(c.completeness(), 2.0 / 3, 1e-12);
  EXPECT_EQ(c.accuracy.within[0], 1);  // 1 %
  EXPECT_EQ(c.accuracy.within[2], 1);  // 5 %
  EXPECT_EQ(c.accuracy.within[3], 2);  // 10 %
  DepthComparison pooled;
  pooled.merge(c);
  pooled.merge(c);
  EXPECT_EQ(pooled.truth_pixels, 6);
  EXPECT_NEAR(pooled.accuracy.fraction(3), 1.0, 1e-12);
  EXPECT_INPUT_ERROR(compareDepth(ImageF(2, 1), truth), "differ", "size");
}

// The true surface of a realism-mode frame is its exact depth at its true
// pose (cams_gt/), not at the tracker's; without a true pose, or for a depth
// camera of its own, the recorded pose is the truth.
TEST(GroundTruthDepth, TrueSurfaceIsPlacedAtTheTruePoseWhereThereIsOne) {
  DepthMapView truth;
  truth.camera = test::centredCamera(8, 6, 10);
  truth.depth = ImageF(8, 6, 1, 2.0f);
  PosedFrame frame;
  frame.ground_truth.path = "depth.pfm";
  PinholeCamera true_camera = test::centredCamera(16, 12, 20);  // another resolution: only the pose counts
  setCameraToWorld(test::poseAt({0.1, -0.2, 0.3}, 30), &true_camera);
  EXPECT_EQ(trueSurfaceView(truth, frame).camera.t, truth.camera.t);  // no true pose: the recorded one
  frame.true_camera = true_camera;
  const DepthMapView placed = trueSurfaceView(truth, frame);
  EXPECT_EQ(placed.camera.R, true_camera.R);
  EXPECT_EQ(placed.camera.t, true_camera.t);
  EXPECT_EQ(placed.camera.fx, truth.camera.fx);
  EXPECT_EQ(placed.camera.width, 8);
  EXPECT_EQ(placed.depth.data, truth.depth.data);
  const std::vector<Eigen::Vector3f> points = backprojectDepthMaps({placed}, 1);
  ASSERT_FALSE(points.empty());
  EXPECT_NEAR((points[0].cast<double>() - true_camera.center()).norm(), 2.0 * std::sqrt(1 + (3.5 * 3.5 + 2.5 * 2.5) / 100.0), 1e-5);
  // A depth camera of its own (1 cm beside the colour camera, both at the
  // tracker's pose) goes where it sits on the true colour camera.
  frame.ground_truth.registered = false;
  setCameraToWorld(test::poseAt({0.5, 0, 0}, 10), &frame.camera);
  DepthMapView beside = truth;
  setCameraToWorld(cameraToWorld(frame.camera) * Eigen::Translation3d(0.01, 0, 0), &beside.camera);
  const Eigen::Isometry3d expected = cameraToWorld(true_camera) * Eigen::Translation3d(0.01, 0, 0);
  EXPECT_TRUE(cameraToWorld(trueSurfaceView(beside, frame).camera).isApprox(expected, 1e-12));
}

}  // namespace
}  // namespace amhmvs
