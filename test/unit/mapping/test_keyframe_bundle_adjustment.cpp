// The keyframe bundle adjustment (keyframe_bundle_adjustment.h): features
// matched between neighbouring keyframes become tracks across all of them;
// the tracker's noisy poses come out agreeing with each other as the images
// say (relative rotations and baseline lengths), at the tracker's mean
// placement; mismatches do not spoil it (nor chain tracks together).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {
namespace {

constexpr double kDegree = M_PI / 180;
constexpr int kKeyframes = 8;

double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() / kDegree;
}

struct Scene {
  std::map<int64_t, Eigen::Isometry3d> truth;     // camera-to-world
  std::map<int64_t, BundleKeyframe> keyframes;    // cameras at the tracker's poses
  std::vector<KeyframeFeatureMatches> matches;    // exact (each keyframe with the next three)
  std::vector<std::vector<int>> feature_of_point;  // per keyframe: point -> feature index (-1: not seen)
};

// 8 keyframes 10 cm apart looking at points 2-4 m away (a 320x240 camera),
// the tracker off by 1 cm and 0.3 deg per axis; features are the points'
// projections with 0.2 px of noise, numbered differently in every keyframe.
Scene scene(unsigned seed = 11) {
  Scene s;
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  // Draws one after another: the arguments of one call are evaluated in an
  // unspecified order, so gcc and clang would see different scenes.
  const auto draws = [&](auto& distribution, int count) {
    Eigen::Vector3d values = Eigen::Vector3d::Zero();
    for (int i = 0; i < count; ++i) values[i] = distribution(random);
    return values;
  };
  const auto noise = [&](double sigma) -> Eigen::Vector3d { return draws(normal, 3) * sigma; };
  std::vector<Eigen::Vector3d> points;
  for (int p = 0; p < 400; ++p) {
    const Eigen::Vector3d u = draws(uniform, 3);
    points.emplace_back(1.5 * u.x() + 0.35, 1.0 * u.y(), 3 + u.z());
  }
  PinholeCamera camera;
  camera.width = 320;
  camera.height = 240;
  camera.fx = camera.fy = 280;
  camera.cx = 159.5;
  camera.cy = 119.5;
  for (int64_t id = 0; id < kKeyframes; ++id) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(0.01 * id, Eigen::Vector3d::UnitY()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.1 * id, 0.01 * id * id, 0);
    s.truth[id] = pose;
    PinholeCamera true_camera = camera;
    setCameraToWorld(pose, &true_camera);
    Eigen::Isometry3d tracked = pose;
    const Eigen::Vector3d turn = noise(0.3 * kDegree);
    tracked.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * pose.linear();
    tracked.translation() += noise(0.01);
    BundleKeyframe keyframe;
    keyframe.camera = camera;
    setCameraToWorld(tracked, &keyframe.camera);
    std::vector<int> order(points.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    std::vector<int> feature_of_point(points.size(), -1);
    for (int p : order) {
      const Eigen::Vector3d in_camera = true_camera.toCamera(points[p]);
      const Eigen::Vector2d exact = true_camera.project(in_camera);
      const Eigen::Vector2d pixel = exact + 0.2 * draws(normal, 2).head<2>();
      if (in_camera.z() <= 0 || pixel.x() < 0 || pixel.y() < 0 || pixel.x() > 319 || pixel.y() > 239) continue;
      feature_of_point[p] = static_cast<int>(keyframe.pixels.size());
      keyframe.pixels.push_back(pixel);
    }
    s.keyframes[id] = keyframe;
    s.feature_of_point.push_back(feature_of_point);
  }
  for (int64_t i = 0; i < kKeyframes; ++i) {
    for (int64_t j = i + 1; j < std::min<int64_t>(kKeyframes, i + 4); ++j) {
      KeyframeFeatureMatches pair{i, j, {}};
      for (size_t p = 0; p < points.size(); ++p) {
        const int a = s.feature_of_point[i][p], b = s.feature_of_point[j][p];
        if (a >= 0 && b >= 0) pair.features.emplace_back(a, b);
      }
      s.matches.push_back(pair);
    }
  }
  return s;
}

struct RelativeErrors {
  double worst_deg = 0;     // relative rotation
  double common_scale = 1;  // median over pairs of baseline length / true
  double worst_spread = 0;  // |length ratio / common_scale - 1|: one scale for all?
};

RelativeErrors relativeErrors(const Scene& s, const std::map<int64_t, Eigen::Isometry3d>& poses) {
  RelativeErrors errors;
  std::vector<double> ratios;
  for (int64_t i = 0; i < kKeyframes; ++i) {
    for (int64_t j = i + 1; j < kKeyframes; ++j) {
      const Eigen::Isometry3d truth = s.truth.at(i).inverse() * s.truth.at(j);
      const Eigen::Isometry3d solved = poses.at(i).inverse() * poses.at(j);
      errors.worst_deg = std::max(errors.worst_deg, angleDeg(truth.linear(), solved.linear()));
      ratios.push_back(solved.translation().norm() / truth.translation().norm());
    }
  }
  std::vector<double> sorted = ratios;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  errors.common_scale = sorted[sorted.size() / 2];
  for (double ratio : ratios) errors.worst_spread = std::max(errors.worst_spread, std::abs(ratio / errors.common_scale - 1));
  return errors;
}

std::map<int64_t, Eigen::Isometry3d> trackerPoses(const Scene& s) {
  std::map<int64_t, Eigen::Isometry3d> poses;
  for (const auto& entry : s.keyframes) poses[entry.first] = cameraToWorld(entry.second.camera);
  return poses;
}

// Three scenes: the worst of them is held.
constexpr unsigned kSeeds[] = {11, 12, 13};

TEST(KeyframeBundleAdjustment, TracksAcrossKeyframesMakeTheirPosesAgree) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  for (unsigned seed : kSeeds) {
    const Scene s = scene(seed);
    const KeyframeBundleAdjustmentResult result =
        adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
    ASSERT_TRUE(result.solved);
    ASSERT_EQ(result.poses.size(), static_cast<size_t>(kKeyframes));
    const RelativeErrors tracker = relativeErrors(s, trackerPoses(s));
    const RelativeErrors adjusted = relativeErrors(s, result.poses);
    std::printf("seed %u: tracks %d, observations %d, rms %.3f -> %.3f px; relative poses, worst: tracker %.3f deg,"
                " length spread %.2f %%; adjusted %.4f deg, spread %.3f %%, common scale %.4f\n",
                seed, result.tracks, result.observations, result.rms_before_px, result.rms_after_px, tracker.worst_deg,
                100 * tracker.worst_spread, adjusted.worst_deg, 100 * adjusted.worst_spread, adjusted.common_scale);
    EXPECT_GT(result.tracks, 300);
    EXPECT_EQ(result.confirmed, 0);  // every keyframe's features say the tracker is off
    EXPECT_GT(result.rms_before_px, 1.0);
    EXPECT_LT(result.rms_after_px, 0.3);  // the features' own noise: 0.2 px per axis
    EXPECT_GT(tracker.worst_deg, 0.4);
    EXPECT_GT(tracker.worst_spread, 0.1);
    // Measured over the three scenes: 0.035-0.102 deg, spread 1.0-1.7 %
    // (the tracker: 1.24-1.67 deg, 10-25 %). The rotation is what 0.2 px
    // features at 2-4 m over 10-70 cm of baseline allow. The common scale
    // is the tracker's mean (its 1 cm noise over a 70 cm path: about 1.5 %;
    // measured 0.971-1.015), not the images'.
    EXPECT_LT(adjusted.worst_deg, 0.15);
    EXPECT_LT(adjusted.worst_spread, 0.025);
    EXPECT_NEAR(adjusted.common_scale, 1.0, 0.05);
    // Where the tracker put the keyframes on average: each within its noise.
    for (const auto& entry : result.poses) {
      EXPECT_LT(angleDeg(entry.second.linear(), s.truth.at(entry.first).linear()), 0.6) << entry.first;
      EXPECT_LT((entry.second.translation() - s.truth.at(entry.first).translation()).norm(), 0.03) << entry.first;
    }
  }
}

TEST(KeyframeBundleAdjustment, MismatchesDoNotSpoilIt) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  for (unsigned seed : kSeeds) {
    Scene s = scene(seed);
    const KeyframeBundleAdjustmentResult clean =
        adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
    // Every fifth match of each pair rotated to another feature: 20 % wrong.
    for (KeyframeFeatureMatches& pair : s.matches) {
      const size_t count = pair.features.size();
      for (size_t m = 0; m < count; m += 5) pair.features[m].second = pair.features[(m + 7) % count].second;
    }
    // And matches that name no keyframe or no feature: ignored.
    s.matches.push_back({0, 99, {{0, 0}}});
    s.matches.push_back({0, 1, {{-1, 3}, {0, 100000}}});
    const KeyframeBundleAdjustmentResult result =
        adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
    ASSERT_TRUE(result.solved);
    const RelativeErrors adjusted = relativeErrors(s, result.poses);
    std::printf("seed %u with 20 %% mismatches: tracks %d (clean %d), rms after %.3f px; worst %.4f deg, spread %.3f %%,"
                " common scale %.4f\n",
                seed, result.tracks, clean.tracks, result.rms_after_px, adjusted.worst_deg, 100 * adjusted.worst_spread,
                adjusted.common_scale);
    // Joins that would give a track two features of one keyframe are refused:
    // most tracks survive the mismatches (measured 82-86 % of the clean
    // runs'; a mismatch splits a track, and two-view pieces leave).
    EXPECT_GT(result.tracks, clean.tracks * 3 / 4);
    EXPECT_LT(result.rms_after_px, 0.3);  // the far-off observations are out of the final solve
    // Measured 0.05-0.20 deg, spread 0.9-1.9 %. With two-view tracks in the
    // final solve 0.20-0.50 deg and up to 7.1 %; with Huber's loss in the
    // first solve as well, up to 1.7 deg and 70 %.
    EXPECT_LT(adjusted.worst_deg, 0.3);
    EXPECT_LT(adjusted.worst_spread, 0.03);
    EXPECT_NEAR(adjusted.common_scale, 1.0, 0.05);
  }
}

// Every other feature coarse (size 8 px against 2 px) and, like a blob whose
// centre moves with the viewing angle, off by 0.4 px more in x in each
// keyframe: weighed like the fine ones, they turn the relative poses;
// weighed by their size (finest_feature_size_px) they cannot.
TEST(KeyframeBundleAdjustment, CoarseFeaturesWeighByTheirSize) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  for (unsigned seed : kSeeds) {
    Scene s = scene(seed);
    for (auto& [id, keyframe] : s.keyframes) {
      for (size_t f = 0; f < keyframe.pixels.size(); ++f) {
        const bool coarse = f % 2 == 1;
        keyframe.sizes.push_back(coarse ? 8.0 : 2.0);
        if (coarse) keyframe.pixels[f].x() += 0.4 * id;
      }
    }
    KeyframeBundleAdjustmentSettings equal;
    KeyframeBundleAdjustmentSettings by_size;
    by_size.finest_feature_size_px = 2;
    EXPECT_DOUBLE_EQ(featureSigmaPx(s.keyframes.at(0), 0, by_size) / by_size.feature_sigma_px,
                     s.keyframes.at(0).sizes[0] / 2);
    EXPECT_DOUBLE_EQ(featureSigmaPx(s.keyframes.at(0), 1, by_size) / by_size.feature_sigma_px,
                     s.keyframes.at(0).sizes[1] / 2);
    EXPECT_DOUBLE_EQ(featureSigmaPx(s.keyframes.at(0), 1, equal), equal.feature_sigma_px);
    const RelativeErrors unweighted = relativeErrors(s, adjustKeyframes(s.keyframes, s.matches, equal).poses);
    const KeyframeBundleAdjustmentResult result = adjustKeyframes(s.keyframes, s.matches, by_size);
    ASSERT_TRUE(result.solved);
    const RelativeErrors weighted = relativeErrors(s, result.poses);
    std::printf("seed %u, coarse features biased: worst %.4f deg, spread %.3f %% equal; %.4f deg, %.3f %% by size\n",
                seed, unweighted.worst_deg, 100 * unweighted.worst_spread, weighted.worst_deg,
                100 * weighted.worst_spread);
    // Measured: 0.259-0.342 deg equal, 0.056-0.157 by size (the unbiased
    // scene: 0.035-0.102, TracksAcrossKeyframesMakeTheirPosesAgree).
    EXPECT_GT(unweighted.worst_deg, 0.25);
    EXPECT_LT(weighted.worst_deg, 0.17);
  }
}

// A tracker that is right: the features (0.2 px of noise) explain nothing
// the poses do not, so every keyframe is confirmed and keeps its pose
// exactly (fitting the noise moved them by 0.02-0.1 deg and cost the
// realism map 15 points within 2 cm with the true poses).
TEST(KeyframeBundleAdjustment, ExactPosesAreConfirmedNotMoved) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  Scene s = scene();
  for (auto& entry : s.keyframes) setCameraToWorld(s.truth.at(entry.first), &entry.second.camera);
  const KeyframeBundleAdjustmentResult result =
      adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
  ASSERT_TRUE(result.solved);
  EXPECT_EQ(result.confirmed, kKeyframes);
  EXPECT_LT(result.rms_before_px, 0.3);
  for (const auto& entry : result.poses) {
    EXPECT_LT(angleDeg(entry.second.linear(), s.truth.at(entry.first).linear()), 1e-9) << entry.first;
    EXPECT_LT((entry.second.translation() - s.truth.at(entry.first).translation()).norm(), 1e-12) << entry.first;
  }
  // Without the rule (threshold 0) the same features move them.
  KeyframeBundleAdjustmentSettings fit_all;
  fit_all.min_explained_rms_px = 0;
  const KeyframeBundleAdjustmentResult moved = adjustKeyframes(s.keyframes, s.matches, fit_all);
  ASSERT_TRUE(moved.solved);
  EXPECT_EQ(moved.confirmed, 0);
  double largest_deg = 0;
  for (const auto& entry : moved.poses)
    largest_deg = std::max(largest_deg, angleDeg(entry.second.linear(), s.truth.at(entry.first).linear()));
  std::printf("exact poses, every keyframe free: moved by up to %.4f deg\n", largest_deg);
  EXPECT_GT(largest_deg, 0.005);
}

TEST(KeyframeBundleAdjustment, NothingToAdjustWithoutTracks) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  const Scene s = scene();
  EXPECT_FALSE(adjustKeyframes(s.keyframes, {}, KeyframeBundleAdjustmentSettings()).solved);
  EXPECT_FALSE(adjustKeyframes({}, s.matches, KeyframeBundleAdjustmentSettings()).solved);
  // Two keyframes make only two-view tracks: too short for the final solve.
  const std::vector<KeyframeFeatureMatches> first_pair(s.matches.begin(), s.matches.begin() + 1);
  EXPECT_FALSE(adjustKeyframes(s.keyframes, first_pair, KeyframeBundleAdjustmentSettings()).solved);
  // Keyframes without an observation are not in the result (0-1 and 0-2:
  // tracks over keyframes 0, 1, 2).
  const std::vector<KeyframeFeatureMatches> first_pairs(s.matches.begin(), s.matches.begin() + 2);
  const KeyframeBundleAdjustmentResult three =
      adjustKeyframes(s.keyframes, first_pairs, KeyframeBundleAdjustmentSettings());
  ASSERT_TRUE(three.solved);
  EXPECT_EQ(three.poses.size(), 3u);
  EXPECT_EQ(three.poses.count(0) + three.poses.count(1) + three.poses.count(2), 3u);
}

}  // namespace
}  // namespace amhmvs
