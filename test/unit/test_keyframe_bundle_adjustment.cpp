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
Scene scene() {
  Scene s;
  std::mt19937 random(11);
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const auto noise = [&](double sigma) -> Eigen::Vector3d {
    return Eigen::Vector3d(normal(random), normal(random), normal(random)) * sigma;
  };
  std::vector<Eigen::Vector3d> points;
  for (int p = 0; p < 400; ++p) points.emplace_back(1.5 * uniform(random) + 0.35, 1.0 * uniform(random), 3 + uniform(random));
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
      const Eigen::Vector2d pixel = true_camera.project(in_camera) + 0.2 * Eigen::Vector2d(normal(random), normal(random));
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
  double worst_deg = 0;           // relative rotation
  double worst_length_ratio = 0;  // |baseline length / true - 1|
};

RelativeErrors relativeErrors(const Scene& s, const std::map<int64_t, Eigen::Isometry3d>& poses) {
  RelativeErrors errors;
  for (int64_t i = 0; i < kKeyframes; ++i) {
    for (int64_t j = i + 1; j < kKeyframes; ++j) {
      const Eigen::Isometry3d truth = s.truth.at(i).inverse() * s.truth.at(j);
      const Eigen::Isometry3d solved = poses.at(i).inverse() * poses.at(j);
      errors.worst_deg = std::max(errors.worst_deg, angleDeg(truth.linear(), solved.linear()));
      errors.worst_length_ratio =
          std::max(errors.worst_length_ratio, std::abs(solved.translation().norm() / truth.translation().norm() - 1));
    }
  }
  return errors;
}

std::map<int64_t, Eigen::Isometry3d> trackerPoses(const Scene& s) {
  std::map<int64_t, Eigen::Isometry3d> poses;
  for (const auto& entry : s.keyframes) poses[entry.first] = cameraToWorld(entry.second.camera);
  return poses;
}

TEST(KeyframeBundleAdjustment, TracksAcrossKeyframesMakeTheirPosesAgree) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  const Scene s = scene();
  const KeyframeBundleAdjustmentResult result = adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
  ASSERT_TRUE(result.solved);
  ASSERT_EQ(result.poses.size(), static_cast<size_t>(kKeyframes));
  const RelativeErrors tracker = relativeErrors(s, trackerPoses(s));
  const RelativeErrors adjusted = relativeErrors(s, result.poses);
  std::printf("tracks %d, observations %d, rms %.3f -> %.3f px; relative poses, worst: tracker %.3f deg, length %.2f %%;"
              " adjusted %.4f deg, length %.3f %%\n",
              result.tracks, result.observations, result.rms_before_px, result.rms_after_px, tracker.worst_deg,
              100 * tracker.worst_length_ratio, adjusted.worst_deg, 100 * adjusted.worst_length_ratio);
  EXPECT_GT(result.tracks, 300);
  EXPECT_GT(result.rms_before_px, 1.0);
  EXPECT_LT(result.rms_after_px, 0.3);  // the features' own noise: 0.2 px per axis
  EXPECT_GT(tracker.worst_deg, 0.4);
  // Measured: 0.033 deg and 0.98 % (the tracker: 1.24 deg, 29 %).
  EXPECT_LT(adjusted.worst_deg, 0.05);
  // One scale for all: the baselines' ratios agree; their common scale is
  // the tracker's (a few tenths of a per cent here, where its pairs are off by up to 20 %).
  EXPECT_GT(tracker.worst_length_ratio, 0.1);
  EXPECT_LT(adjusted.worst_length_ratio, 0.015);
  // Where the tracker put the keyframes on average: each within its noise.
  for (const auto& entry : result.poses) {
    EXPECT_LT(angleDeg(entry.second.linear(), s.truth.at(entry.first).linear()), 0.6) << entry.first;
    EXPECT_LT((entry.second.translation() - s.truth.at(entry.first).translation()).norm(), 0.02) << entry.first;
  }
}

TEST(KeyframeBundleAdjustment, MismatchesDoNotSpoilIt) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  Scene s = scene();
  const KeyframeBundleAdjustmentResult clean = adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
  // Every fifth match of each pair rotated to another feature: 20 % wrong.
  for (KeyframeFeatureMatches& pair : s.matches) {
    const size_t count = pair.features.size();
    for (size_t m = 0; m < count; m += 5) pair.features[m].second = pair.features[(m + 7) % count].second;
  }
  // And matches that name no keyframe or no feature: ignored.
  s.matches.push_back({0, 99, {{0, 0}}});
  s.matches.push_back({0, 1, {{-1, 3}, {0, 100000}}});
  const KeyframeBundleAdjustmentResult result = adjustKeyframes(s.keyframes, s.matches, KeyframeBundleAdjustmentSettings());
  ASSERT_TRUE(result.solved);
  const RelativeErrors adjusted = relativeErrors(s, result.poses);
  std::printf("with 20 %% mismatches: tracks %d (clean %d), rms after %.3f px; worst %.4f deg, length %.3f %%\n",
              result.tracks, clean.tracks, result.rms_after_px, adjusted.worst_deg, 100 * adjusted.worst_length_ratio);
  // Joins that would give a track two features of one keyframe are refused:
  // most tracks survive the mismatches (measured 367 of 397).
  EXPECT_GT(result.tracks, clean.tracks * 9 / 10);
  EXPECT_LT(result.rms_after_px, 0.3);  // the far-off observations are out of the final solve
  // Measured 0.20 deg and 1.9 %: a mismatch splits a track in two, and
  // shorter tracks hold the poses less well than the clean run's (0.033 deg,
  // 0.98 %); still a sixth and a fifteenth of the tracker's error. Leaving out
  // every track that lost an observation (181 tracks: 0.14 deg, 2.5 %) or
  // observations off by 20 px at the tracker's poses before the first solve
  // (302 tracks: 0.69 deg, 15 %) was worse.
  EXPECT_LT(adjusted.worst_deg, 0.3);
  EXPECT_LT(adjusted.worst_length_ratio, 0.03);
}

TEST(KeyframeBundleAdjustment, NothingToAdjustWithoutTracks) {
  if (!keyframeBundleAdjustmentAvailable()) GTEST_SKIP() << "this build has no Ceres";
  const Scene s = scene();
  EXPECT_FALSE(adjustKeyframes(s.keyframes, {}, KeyframeBundleAdjustmentSettings()).solved);
  EXPECT_FALSE(adjustKeyframes({}, s.matches, KeyframeBundleAdjustmentSettings()).solved);
  // Keyframes without an observation are not in the result.
  std::vector<KeyframeFeatureMatches> first_pair(s.matches.begin(), s.matches.begin() + 1);
  const KeyframeBundleAdjustmentResult two = adjustKeyframes(s.keyframes, first_pair, KeyframeBundleAdjustmentSettings());
  ASSERT_TRUE(two.solved);
  EXPECT_EQ(two.poses.size(), 2u);
  EXPECT_EQ(two.poses.count(0) + two.poses.count(1), 2u);
}

}  // namespace
}  // namespace amhmvs
