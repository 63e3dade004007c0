// Per-keyframe depth range (depth_range.h): from the given range, sparse
// points, neighbours' finished depth maps, or the default, with a reason, and
// always a finite 0 < min < max range.
#include "amhmvs_mapping/mapping/depth_range.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "mapping_test_helpers.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr int kWidth = test::kKeyframeWidth, kHeight = test::kKeyframeHeight;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Keyframe makeKeyframe(int64_t id, const Eigen::Vector3d& position) {
  return test::smallKeyframe(id, static_cast<double>(id), test::poseAt(position));
}

void expectUsable(const DepthRangeEstimate& estimate) {
  EXPECT_TRUE(std::isfinite(estimate.min) && std::isfinite(estimate.max));
  EXPECT_GT(estimate.min, 0);
  EXPECT_LT(estimate.min, estimate.max);
  EXPECT_FALSE(estimate.reason.empty());
}

TEST(DepthRange, FromSparsePointsWithPercentilesAndFactors) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  // 101 points on the optical axis at z = 2.00 .. 4.00, plus points that must
  // be ignored: behind the camera, outside the image, not finite.
  for (int i = 0; i <= 100; ++i) keyframe.sparse_points.emplace_back(0, 0, 2.0 + 0.02 * i);
  keyframe.sparse_points.emplace_back(0, 0, -50);
  keyframe.sparse_points.emplace_back(100, 0, 1);
  keyframe.sparse_points.emplace_back(kNaN, 0, 1);
  const DepthRangeEstimate estimate = estimateDepthRange(keyframe, {});
  expectUsable(estimate);
  EXPECT_EQ(estimate.source, DepthRangeSource::kSparsePoints);
  EXPECT_EQ(estimate.samples, 101u);
  EXPECT_NEAR(estimate.min, 0.8 * 2.04, 1e-9);  // p2 of 101 evenly spaced = 3rd value
  EXPECT_NEAR(estimate.max, 1.2 * 3.96, 1e-9);
  EXPECT_NE(estimate.reason.find("from 101 sparse points"), std::string::npos) << estimate.reason;
}

TEST(DepthRange, PercentilesIgnoreOutliers) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  for (int i = 0; i < 200; ++i) keyframe.sparse_points.emplace_back(0, 0, 3.0 + 0.001 * i);
  keyframe.sparse_points.emplace_back(0, 0, 1e6);   // one far outlier
  keyframe.sparse_points.emplace_back(0, 0, 1e-6);  // one near outlier
  const DepthRangeEstimate estimate = estimateDepthRange(keyframe, {});
  // Inlier depths span 3.0 .. 3.2: the range stays near [0.8 * 3.0, 1.2 * 3.2].
  EXPECT_GT(estimate.min, 0.8 * 2.99);
  EXPECT_LT(estimate.max, 1.2 * 3.21);
}

TEST(DepthRange, AllPointsAtOneDepthStillGiveAProperRange) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  keyframe.sparse_points.assign(20, Eigen::Vector3d(0, 0, 5));
  const DepthRangeEstimate estimate = estimateDepthRange(keyframe, {});
  expectUsable(estimate);
  EXPECT_DOUBLE_EQ(estimate.min, 4.0);
  EXPECT_DOUBLE_EQ(estimate.max, 6.0);
}

TEST(DepthRange, GivenRangeComesFirst) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  keyframe.depth_min = 1.5;
  keyframe.depth_max = 2.5;
  keyframe.sparse_points.assign(20, Eigen::Vector3d(0, 0, 5));
  DepthRangeEstimate estimate = estimateDepthRange(keyframe, {});
  EXPECT_EQ(estimate.source, DepthRangeSource::kGiven);
  EXPECT_EQ(estimate.min, 1.5);
  EXPECT_EQ(estimate.max, 2.5);
  DepthRangeOptions options;
  options.use_given_range = false;
  estimate = estimateDepthRange(keyframe, {}, options);
  EXPECT_EQ(estimate.source, DepthRangeSource::kSparsePoints);
  // An inverted given range (not validated by a store) is not used.
  keyframe.depth_min = 3;
  keyframe.depth_max = 2;
  estimate = estimateDepthRange(keyframe, {});
  EXPECT_EQ(estimate.source, DepthRangeSource::kSparsePoints);
  EXPECT_NE(estimate.reason.find("unusable"), std::string::npos) << estimate.reason;
}

TEST(DepthRange, FromNeighbourDepthMapsWhenTooFewPoints) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  keyframe.sparse_points.assign(3, Eigen::Vector3d(0, 0, 5));  // too few
  // A neighbour 0.3 m to the side sees a wall at z = 4; some pixels are
  // invalid.
  const Keyframe neighbour = makeKeyframe(2, Eigen::Vector3d(0.3, 0, 0));
  ImageF depth(kWidth, kHeight, 1, 4.0f);
  for (int x = 0; x < kWidth; ++x) depth.at(x, 0) = std::numeric_limits<float>::quiet_NaN();
  depth.at(3, 3) = -1.0f;
  depth.at(5, 5) = std::numeric_limits<float>::infinity();
  const DepthRangeEstimate estimate =
      estimateDepthRange(keyframe, {{2, &neighbour.camera, &depth}});
  expectUsable(estimate);
  EXPECT_EQ(estimate.source, DepthRangeSource::kNeighbourDepthMaps);
  EXPECT_NEAR(estimate.min, 0.8 * 4.0, 1e-5);
  EXPECT_NEAR(estimate.max, 1.2 * 4.0, 1e-5);
  EXPECT_GE(estimate.samples, 100u);
  EXPECT_NE(estimate.reason.find("3 sparse points in view < 10"), std::string::npos)
      << estimate.reason;
}

// A neighbour at the keyframe's pose (200x100 px) that sees depths 2..4 m
// (rising along x) with a low matching cost, and planted outliers at 0.1 m:
// `share` of the pixels (in 2x2 blocks, so that the sampled pixels have the
// same share) with matching cost `outlier_cost`.
struct PlantedNeighbour {
  PinholeCamera camera = test::centredCamera(200, 100, 150);
  ImageF depth{200, 100, 1, 0.0f}, cost{200, 100, 1, 0.2f};
  PlantedNeighbour(double share, float outlier_cost) {
    const int every = static_cast<int>(std::lround(1.0 / share));
    for (int y = 0; y < depth.height; ++y) {
      for (int x = 0; x < depth.width; ++x) {
        depth.at(x, y) = static_cast<float>(2.0 + 2.0 * x / (depth.width - 1));
        if (share > 0 && (x / 2 + (y / 2) * (depth.width / 2)) % every == 0) {
          depth.at(x, y) = 0.1f;
          cost.at(x, y) = outlier_cost;
        }
      }
    }
  }
  DepthRangeEstimate range(const DepthRangeOptions& options = DepthRangeOptions()) const {
    Keyframe keyframe;
    keyframe.id = 1;
    keyframe.camera = camera;
    return estimateDepthRange(keyframe, {{2, &camera, &depth, &cost}}, options);
  }
};

TEST(DepthRange, NeighbourOutliersAtATenthOfAMetreDoNotPullTheNearLimit) {
  const DepthRangeEstimate clean = PlantedNeighbour(0, 0).range();
  ASSERT_EQ(clean.source, DepthRangeSource::kNeighbourDepthMaps) << clean.reason;
  // True depths 2..4 m: the range holds them, with the margin (0.8 / 1.2).
  EXPECT_GT(clean.min, 0.75 * 2.0);
  EXPECT_LT(clean.min, 2.0);
  EXPECT_GT(clean.max, 4.0);
  EXPECT_LT(clean.max, 1.25 * 4.0);

  // 2 % of the pixels at 0.1 m, even confident ones (low cost): the robust
  // percentiles keep the range within 5 % of the outlier-free one.
  const DepthRangeEstimate two_percent = PlantedNeighbour(0.02, 0.2f).range();
  EXPECT_NEAR(two_percent.min, clean.min, 0.05 * clean.min) << two_percent.reason;
  EXPECT_NEAR(two_percent.max, clean.max, 0.05 * clean.max) << two_percent.reason;
  // So do 3 %, which a 2 % percentile would not survive.
  const PlantedNeighbour confident_outliers(0.03, 0.2f);
  const DepthRangeEstimate robust = confident_outliers.range();
  EXPECT_NEAR(robust.min, clean.min, 0.05 * clean.min) << robust.reason;
  EXPECT_NEAR(robust.max, clean.max, 0.05 * clean.max) << robust.reason;
  // The planted outliers do matter: the sparse points' 2 % percentile would
  // put the near limit below 0.5 m.
  DepthRangeOptions plain;
  plain.neighbour_low_percentile = 2.0;
  plain.max_neighbour_cost = 2.0;
  EXPECT_LT(confident_outliers.range(plain).min, 0.5);

  // 20 % at 0.1 m with the high cost that PatchMatch gives wrong pixels: only
  // confident pixels are sampled, so they are not seen at all.
  const PlantedNeighbour costly_outliers(0.2, 1.2f);
  const DepthRangeEstimate confident = costly_outliers.range();
  EXPECT_NEAR(confident.min, clean.min, 0.05 * clean.min) << confident.reason;
  EXPECT_NEAR(confident.max, clean.max, 0.05 * clean.max) << confident.reason;
  EXPECT_NE(confident.reason.find("confident depth samples"), std::string::npos) << confident.reason;
  plain.max_neighbour_cost = 2.0;
  plain.neighbour_low_percentile = 5.0;
  EXPECT_LT(costly_outliers.range(plain).min, 0.5);  // the cost is what removes them
}

TEST(DepthRange, TooFewConfidentNeighbourPixelsFallBackToAllValidOnes) {
  // Every pixel unconfident: the range still comes from the depth map (say so).
  const PlantedNeighbour neighbour(0, 0);
  DepthRangeOptions options;
  options.max_neighbour_cost = 0.1;  // below every pixel's 0.2
  const DepthRangeEstimate estimate = neighbour.range(options);
  EXPECT_EQ(estimate.source, DepthRangeSource::kNeighbourDepthMaps);
  EXPECT_NEAR(estimate.min, PlantedNeighbour(0, 0).range().min, 1e-9);
  EXPECT_NE(estimate.reason.find("too few confident: 0"), std::string::npos) << estimate.reason;
}

TEST(DepthRange, DefaultWithReasonWhenNothingElseWorks) {
  const Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  // A neighbour looking at nothing the keyframe sees (all depths invalid).
  const Keyframe neighbour = makeKeyframe(2, Eigen::Vector3d(0.3, 0, 0));
  const ImageF invalid(kWidth, kHeight, 1, std::numeric_limits<float>::quiet_NaN());
  DepthRangeOptions options;
  options.default_min = 0.7;
  options.default_max = 7;
  const DepthRangeEstimate estimate =
      estimateDepthRange(keyframe, {{2, &neighbour.camera, &invalid}}, options);
  expectUsable(estimate);
  EXPECT_EQ(estimate.source, DepthRangeSource::kDefault);
  EXPECT_EQ(estimate.min, 0.7);
  EXPECT_EQ(estimate.max, 7.0);
  EXPECT_NE(estimate.reason.find("0 sparse points"), std::string::npos) << estimate.reason;
  EXPECT_NE(estimate.reason.find("0 depth samples from 1 neighbour"), std::string::npos);
  EXPECT_STREQ(depthRangeSourceName(estimate.source), "default");
}

TEST(DepthRange, HugeDepthsFallBackInsteadOfInfinity) {
  Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  keyframe.sparse_points.assign(20, Eigen::Vector3d(0, 0, 1.6e308));  // * 1.2 overflows
  const DepthRangeEstimate estimate = estimateDepthRange(keyframe, {});
  expectUsable(estimate);
  EXPECT_EQ(estimate.source, DepthRangeSource::kDefault);
  EXPECT_NE(estimate.reason.find("unusable range"), std::string::npos) << estimate.reason;
}

TEST(DepthRange, BadInputIsAClearError) {
  const Keyframe keyframe = makeKeyframe(1, Eigen::Vector3d::Zero());
  const Keyframe neighbour = makeKeyframe(7, Eigen::Vector3d(0.3, 0, 0));
  const ImageF wrong_size(16, 12, 1, 2.0f);
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {{7, &neighbour.camera, &wrong_size}}),
                     "neighbour keyframe 7", "depth map is 16x12x1 but its camera is 32x24");
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {{7, &neighbour.camera, nullptr}}),
                     "neighbour keyframe 7", "null");
  Keyframe bad_neighbour = neighbour;
  bad_neighbour.camera.R(0, 0) = kNaN;
  const ImageF depth(kWidth, kHeight, 1, 2.0f);
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {{7, &bad_neighbour.camera, &depth}}),
                     "neighbour keyframe 7", "non-finite");
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {{7, &neighbour.camera, &depth, &wrong_size}}),
                     "neighbour keyframe 7", "cost image does not match");
  Keyframe bad = keyframe;
  bad.camera.R *= 3;
  EXPECT_INPUT_ERROR(estimateDepthRange(bad, {}), "keyframe 1", "not rigid");
  DepthRangeOptions options;
  options.default_min = 5;
  options.default_max = 1;
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {}, options), "default range", "min < max");
  options = DepthRangeOptions();
  options.neighbour_low_percentile = 96;
  EXPECT_INPUT_ERROR(estimateDepthRange(keyframe, {}, options), "neighbour percentiles", "low < high");
}

TEST(DepthRange, FromStoreUsesFinishedNeighbours) {
  KeyframeStore store;
  store.add(makeKeyframe(1, Eigen::Vector3d::Zero()));
  store.add(makeKeyframe(2, Eigen::Vector3d(0.3, 0, 0)));
  store.add(makeKeyframe(3, Eigen::Vector3d(-0.3, 0, 0)));  // pending: skipped
  DepthMap depth;
  depth.depth = ImageF(kWidth, kHeight, 1, 4.0f);
  store.attachDepth(2, depth);
  const DepthRangeEstimate estimate = estimateDepthRange(store, 1, {2, 3});
  EXPECT_EQ(estimate.source, DepthRangeSource::kNeighbourDepthMaps);
  EXPECT_NEAR(estimate.min, 3.2, 1e-5);
  EXPECT_INPUT_ERROR(estimateDepthRange(store, 9, {}), "keyframe 9", "unknown id");
  EXPECT_INPUT_ERROR(estimateDepthRange(store, 1, {9}), "keyframe 9", "unknown id");
}

}  // namespace
}  // namespace amhmvs
