// Cloud metrics on hand-made clouds with known answers, the voxel-grid search
// against brute force, and clouds from depth maps.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

TEST(CloudMetrics, HandMadeCloudsGiveExactFractions) {
  // Reconstruction: 4 points at distances 0.005, 0.015, 0.03 and 1 from the
  // nearest ground-truth point. Ground truth: 5 points, 2 of them near the
  // reconstruction (0.005 and 0.015), the rest far away.
  const std::vector<Eigen::Vector3f> reconstruction = {
      {0, 0, 0.005f}, {1, 0.015f, 0}, {2, 0, 0.03f}, {10, 0, 1}};
  const std::vector<Eigen::Vector3f> ground_truth = {
      {0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {10, 0, 0}, {50, 50, 50}};
  const CloudMetrics m = evaluateCloud(reconstruction, ground_truth, {0.01, 0.02, 0.05});
  EXPECT_EQ(m.reconstruction_points, 4u);
  EXPECT_EQ(m.ground_truth_points, 5u);
  EXPECT_DOUBLE_EQ(m.accuracy[0], 0.25);
  EXPECT_DOUBLE_EQ(m.accuracy[1], 0.5);
  EXPECT_DOUBLE_EQ(m.accuracy[2], 0.75);
  EXPECT_DOUBLE_EQ(m.completeness[0], 0.2);
  EXPECT_DOUBLE_EQ(m.completeness[1], 0.4);
  EXPECT_DOUBLE_EQ(m.completeness[2], 0.6);
  EXPECT_DOUBLE_EQ(m.f1[2], 2 * 0.75 * 0.6 / 1.35);
  EXPECT_NE(m.table().find("75.00%"), std::string::npos) << m.table();

  const CloudMetrics same = evaluateCloud(ground_truth, ground_truth, {1e-6});
  EXPECT_DOUBLE_EQ(same.accuracy[0], 1.0);
  EXPECT_DOUBLE_EQ(same.completeness[0], 1.0);
  const CloudMetrics empty = evaluateCloud({}, ground_truth, {0.1});
  EXPECT_DOUBLE_EQ(empty.accuracy[0], 0.0);
  EXPECT_DOUBLE_EQ(empty.completeness[0], 0.0);
  EXPECT_DOUBLE_EQ(empty.f1[0], 0.0);
}

TEST(CloudMetrics, NearestPointIndexMatchesBruteForce) {
  // A flat spread of points, a dense clump (a surface seen many times) and
  // exact duplicates.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-2, 2);
  std::vector<Eigen::Vector3f> points(3000);
  for (auto& p : points) p = {u(rng), u(rng), u(rng) * 0.1f};
  for (int i = 0; i < 2000; ++i) points.emplace_back(0.3f + 0.01f * u(rng), -0.2f + 0.01f * u(rng), 0.0f);
  for (int i = 0; i < 50; ++i) points.push_back(points[i]);
  const NearestPointIndex index(points);
  ASSERT_EQ(index.size(), points.size());
  for (int q = 0; q < 600; ++q) {
    const Eigen::Vector3f query = q % 3 == 0 ? Eigen::Vector3f(0.3f + 0.05f * u(rng), -0.2f + 0.05f * u(rng), 0.02f * u(rng))
                                             : Eigen::Vector3f(u(rng), u(rng), u(rng) * 0.1f);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : points) best = std::min(best, (p - query).cast<double>().norm());
    for (double radius : {0.0, 0.001, 0.01, 0.05, 0.2, 10.0}) {
      const double found = index.nearestDistance(query, radius);
      if (best <= radius) {
        EXPECT_NEAR(found, best, 1e-9);
      } else {
        EXPECT_TRUE(std::isinf(found));
      }
    }
  }
  // A point exactly at the radius counts; an indexed point is at distance 0.
  EXPECT_EQ(NearestPointIndex({{1, 0, 0}}).nearestDistance({0, 0, 0}, 1.0), 1.0);
  EXPECT_EQ(index.nearestDistance(points[17], 0.0), 0.0);
  EXPECT_TRUE(std::isinf(NearestPointIndex({}).nearestDistance({0, 0, 0}, 10)));
}

TEST(CloudMetrics, BadInputIsRefused) {
  const std::vector<Eigen::Vector3f> cloud = {{0, 0, 0}};
  EXPECT_INPUT_ERROR(evaluateCloud(cloud, cloud, {}), "cloud metrics", "no thresholds");
  EXPECT_INPUT_ERROR(evaluateCloud(cloud, cloud, {0.1, -1}), "cloud metrics", "positive");
  const std::vector<Eigen::Vector3f> nan_cloud = {
      {0, std::numeric_limits<float>::quiet_NaN(), 0}};
  EXPECT_INPUT_ERROR(evaluateCloud(nan_cloud, cloud, {0.1}), "point 0", "not finite");
  EXPECT_INPUT_ERROR(NearestPointIndex{nan_cloud}, "nearest-point index", "point 0");
}

PinholeCamera testCamera() {
  PinholeCamera c = test::centredCamera(100, 80, 100);
  c.t = Eigen::Vector3d(0.5, 0, 0);
  return c;
}

TEST(CloudMetrics, BackprojectedDepthMapsAtAnyResolution) {
  const PinholeCamera camera = testCamera();
  // A half-resolution depth map of the plane z = 2 with one hole.
  ImageF depth(50, 40, 1, 2.0f);
  depth.at(3, 4) = std::numeric_limits<float>::quiet_NaN();
  const auto all = backprojectDepthMaps({{camera, depth}}, 1);
  EXPECT_EQ(all.size(), 50u * 40 - 1);
  const auto strided = backprojectDepthMaps({{camera, depth}}, 2);
  EXPECT_EQ(strided.size(), 25u * 20);  // the hole at odd x is not sampled
  const PinholeCamera half = camera.resized(50, 40);
  for (const auto& p : all) {
    const Eigen::Vector3d c = half.toCamera(p.cast<double>());
    EXPECT_NEAR(c.z(), 2.0, 1e-5);
    ASSERT_TRUE(half.contains(half.project(c)));
  }
  EXPECT_INPUT_ERROR(backprojectDepthMaps({{camera, depth}}, 0), "back-projection", "stride");
  EXPECT_INPUT_ERROR(backprojectDepthMaps({{camera, ImageF(50, 50)}}, 1), "depth map 0",
                     "aspect ratio");
}

TEST(CloudMetrics, RenderedPointDepthKeepsTheNearest) {
  const PinholeCamera camera = testCamera();
  const Eigen::Matrix3d Rt = camera.R.transpose();
  auto world = [&](double u, double v, double z) {
    return (Rt * (camera.backproject(u, v, z) - camera.t)).cast<float>().eval();
  };
  const std::vector<Eigen::Vector3f> points = {world(10, 10, 3), world(10, 10, 2),
                                               world(60, 30, 5), world(-5, 3, 1)};
  const ImageF d0 = renderPointDepth(points, camera, 0);
  EXPECT_FLOAT_EQ(d0.at(10, 10), 2.0f);
  EXPECT_FLOAT_EQ(d0.at(60, 30), 5.0f);
  EXPECT_TRUE(std::isnan(d0.at(61, 30)));
  const ImageF d1 = renderPointDepth(points, camera, 1);
  EXPECT_FLOAT_EQ(d1.at(61, 31), 5.0f);
  EXPECT_TRUE(std::isnan(d1.at(62, 30)));
}

}  // namespace
}  // namespace amhmvs
