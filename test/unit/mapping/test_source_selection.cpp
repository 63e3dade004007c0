// Source-view selection (source_selection.h) on synthetic trajectories:
// sideways and forward motion, pure rotation, duplicate poses, keyframes far
// apart or looking elsewhere; ranking, ties and readable rejections.
#include "amhmvs_mapping/mapping/source_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "mapping_test_helpers.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr int kWidth = test::kKeyframeWidth, kHeight = test::kKeyframeHeight;
using test::poseAt;

Keyframe makeKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  return test::smallKeyframe(id, static_cast<double>(id), camera_to_world);
}

// Target at the origin looking down +z at a wall of sparse points at z = 3.
Keyframe makeTarget(int64_t id = 0) {
  Keyframe target = makeKeyframe(id, Eigen::Isometry3d::Identity());
  for (int i = -5; i <= 5; ++i) {
    for (int j = -3; j <= 3; ++j) target.sparse_points.emplace_back(0.3 * i, 0.3 * j, 3.0);
  }
  return target;
}

std::vector<const Keyframe*> pointers(const std::vector<Keyframe>& keyframes) {
  std::vector<const Keyframe*> out;
  for (const Keyframe& keyframe : keyframes) out.push_back(&keyframe);
  return out;
}

const SourceViewCandidate& candidate(const SourceSelection& selection, int64_t id) {
  for (const SourceViewCandidate& c : selection.candidates) {
    if (c.id == id) return c;
  }
  throw std::runtime_error("no candidate " + std::to_string(id));
}

TEST(SourceSelection, SceneDepthFromSparsePointsRangeOrDefault) {
  const SourceSelectionOptions options;
  const SceneDepth from_points = sceneDepth(makeTarget(), options);
  EXPECT_DOUBLE_EQ(from_points.depth, 3.0);
  EXPECT_NE(from_points.source.find("sparse points"), std::string::npos);

  Keyframe ranged = makeKeyframe(1, Eigen::Isometry3d::Identity());
  ranged.sparse_points = {Eigen::Vector3d(0, 0, -2)};  // behind: ignored
  ranged.depth_min = 2;
  ranged.depth_max = 6;
  EXPECT_DOUBLE_EQ(sceneDepth(ranged, options).depth, 4.0);
  EXPECT_NE(sceneDepth(ranged, options).source.find("depth range"), std::string::npos);

  const Keyframe bare = makeKeyframe(2, Eigen::Isometry3d::Identity());
  EXPECT_DOUBLE_EQ(sceneDepth(bare, options).depth, options.default_scene_depth);
  EXPECT_NE(sceneDepth(bare, options).source.find("default"), std::string::npos);
}

TEST(SourceSelection, SidewaysMotionRankedByAngleAndOverlap) {
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes;
  const double shifts[] = {0.04, 0.2, 0.4, 1.0, 2.5};
  for (int i = 0; i < 5; ++i) {
    keyframes.push_back(makeKeyframe(i + 1, poseAt(Eigen::Vector3d(shifts[i], 0, 0))));
  }
  const SourceSelection selection = selectSources(target, pointers(keyframes));
  EXPECT_TRUE(selection.reason.empty()) << selection.reason;
  // 0.4 m: ~7.6 deg, near the preferred 5 deg with large overlap; then 0.2 m
  // (~3.8 deg, the Gaussian is narrow below 5 deg), then 1 m (~18 deg).
  EXPECT_EQ(selection.source_ids, (std::vector<int64_t>{3, 2, 4}));
  // atan(0.4 / 3) = 7.6 deg on the axis; the median over the grid is lower.
  EXPECT_GT(candidate(selection, 3).triangulation_angle_deg, 6.5);
  EXPECT_LT(candidate(selection, 3).triangulation_angle_deg, 7.6);
  EXPECT_NEAR(candidate(selection, 3).baseline_m, 0.4, 1e-12);
  EXPECT_NEAR(candidate(selection, 3).axis_angle_deg, 0.0, 1e-6);
  EXPECT_GT(candidate(selection, 3).score, candidate(selection, 2).score);
  EXPECT_GT(candidate(selection, 2).score, candidate(selection, 4).score);
  EXPECT_EQ(candidate(selection, 1).rejection.rfind("triangulation angle 0.", 0), 0u)
      << candidate(selection, 1).rejection;
  EXPECT_NE(candidate(selection, 1).rejection.find("deg < 1"), std::string::npos);
  EXPECT_EQ(candidate(selection, 5).rejection.rfind("overlap ", 0), 0u)
      << candidate(selection, 5).rejection;
  EXPECT_NE(candidate(selection, 5).rejection.find("% < 30 %"), std::string::npos);
  EXPECT_EQ(candidate(selection, 5).score, 0.0);
  // Selected first in rank order, then the rejected by id.
  ASSERT_EQ(selection.candidates.size(), 5u);
  EXPECT_EQ(selection.candidates[3].id, 1);
  EXPECT_EQ(selection.candidates[4].id, 5);
}

TEST(SourceSelection, ALargeStoreEvaluatesOnlyTheCandidatesNearestThePreferredAngle) {
  // 400 keyframes along a sideways line and 100 looking the other way: the
  // bounded evaluation picks what evaluating all of them picks.
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes;
  for (int i = -200; i <= 200; ++i) {
    if (i == 0) continue;  // the target's own place
    const Eigen::Vector3d centre(0.01 * i, 0.003 * (i % 7), 0);
    keyframes.push_back(makeKeyframe(static_cast<int64_t>(keyframes.size()) + 1, poseAt(centre)));
  }
  for (int i = 0; i < 100; ++i) {
    Eigen::Isometry3d away = poseAt(Eigen::Vector3d(0.01 * (i + 1), 0, 0));
    away.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
    keyframes.push_back(makeKeyframe(static_cast<int64_t>(keyframes.size()) + 1, away));
  }
  SourceSelectionOptions all;
  all.max_candidates = 10000;
  const SourceSelection reference = selectSources(target, pointers(keyframes), all);
  const SourceSelection bounded = selectSources(target, pointers(keyframes));
  ASSERT_EQ(reference.source_ids.size(), 8u) << reference.reason;
  EXPECT_EQ(bounded.source_ids, reference.source_ids);
  ASSERT_EQ(bounded.candidates.size(), keyframes.size());
  int skipped = 0, axes = 0;
  for (const SourceViewCandidate& c : bounded.candidates) {
    if (c.rejection.find("candidates nearest the preferred angle") != std::string::npos) ++skipped;
    if (c.rejection.rfind("optical axes", 0) == 0) ++axes;
  }
  EXPECT_EQ(axes, 100);
  EXPECT_EQ(skipped, 400 - SourceSelectionOptions().max_candidates);
}

TEST(SourceSelection, FromALargeStoreOnlyTheNearestKeyframesAreCandidates) {
  // 300 keyframes along a sideways line: the store's selection reads the 128
  // nearest the target and picks what reading all of them picks.
  KeyframeStore store;
  store.add(makeTarget(0));
  for (int64_t id = 1; id <= 300; ++id) {
    const double side = (id % 2 ? 1.0 : -1.0) * 0.004 * id;
    store.add(makeKeyframe(id, poseAt(Eigen::Vector3d(side, 0.001 * (id % 5), 0))));
  }
  SourceSelectionOptions all;
  all.max_candidates = 10000;
  const SourceSelection reference = selectSources(store, 0, store.ids(), all);
  const SourceSelection nearest = selectSources(store, 0);
  ASSERT_EQ(reference.source_ids.size(), 8u) << reference.reason;
  EXPECT_EQ(nearest.source_ids, reference.source_ids);
  ASSERT_EQ(nearestCandidateCount(SourceSelectionOptions()), 128u);
  ASSERT_EQ(nearest.candidates.size(), 128u);
  // The candidates are the 64 nearest on each side.
  for (const SourceViewCandidate& c : nearest.candidates) EXPECT_LE(c.id, 128) << c.id;
}

TEST(SourceSelection, ForwardMotionTriangulatesOffAxis) {
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes = {
      makeKeyframe(1, poseAt(Eigen::Vector3d(0, 0, -1))),  // behind: sees all of it
      makeKeyframe(2, poseAt(Eigen::Vector3d(0, 0, 1))),   // ahead: sees the middle
  };
  const SourceSelection selection = selectSources(target, pointers(keyframes));
  ASSERT_EQ(selection.source_ids.size(), 2u) << selection.reason;
  EXPECT_DOUBLE_EQ(candidate(selection, 1).overlap, 1.0);
  EXPECT_GT(candidate(selection, 2).overlap, 0.3);
  EXPECT_LT(candidate(selection, 2).overlap, 0.6);
  EXPECT_GT(candidate(selection, 1).triangulation_angle_deg, 1.0);
  EXPECT_GT(candidate(selection, 2).triangulation_angle_deg, 1.0);
}

TEST(SourceSelection, PureRotationAndDuplicatePosesAreRejected) {
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes = {
      makeKeyframe(1, poseAt(Eigen::Vector3d::Zero(), 10)),  // pure rotation
      makeKeyframe(2, Eigen::Isometry3d::Identity()),        // duplicate
  };
  const SourceSelection selection = selectSources(target, pointers(keyframes));
  EXPECT_TRUE(selection.source_ids.empty());
  EXPECT_EQ(candidate(selection, 1).rejection.rfind("pure rotation: baseline 0.000 m", 0), 0u)
      << candidate(selection, 1).rejection;
  EXPECT_EQ(candidate(selection, 2).rejection.rfind("duplicate pose: baseline 0.000 m", 0), 0u)
      << candidate(selection, 2).rejection;
  EXPECT_NE(selection.reason.find("keyframe 0: none of 2 candidates qualifies"), std::string::npos)
      << selection.reason;
  EXPECT_NE(selection.reason.find("keyframe 1: pure rotation"), std::string::npos);
  EXPECT_NE(selection.reason.find("keyframe 2: duplicate pose"), std::string::npos);
}

TEST(SourceSelection, FarApartOrLookingElsewhereAreRejected) {
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes = {
      makeKeyframe(1, poseAt(Eigen::Vector3d(100, 0, 0))),
      makeKeyframe(2, poseAt(Eigen::Vector3d(0.5, 0, 0), 72)),
      makeKeyframe(3, poseAt(Eigen::Vector3d(0, 0, 1000))),  // beyond the scene, same axis
  };
  const SourceSelection selection = selectSources(target, pointers(keyframes));
  EXPECT_TRUE(selection.source_ids.empty());
  EXPECT_EQ(candidate(selection, 1).rejection, "overlap 0 % < 30 %");
  EXPECT_EQ(candidate(selection, 2).rejection, "optical axes 72 deg apart > 45");
  EXPECT_EQ(candidate(selection, 3).rejection, "overlap 0 % < 30 %");
}

TEST(SourceSelection, WideBaselineAboveMaxAngleIsRejected) {
  const Keyframe target = makeTarget();
  // 2 m sideways, turned 30 deg back towards the scene: large overlap but a
  // ~34 deg triangulation angle.
  std::vector<Keyframe> keyframes = {makeKeyframe(1, poseAt(Eigen::Vector3d(2, 0, 0), -33))};
  const SourceSelection selection = selectSources(target, pointers(keyframes));
  EXPECT_TRUE(selection.source_ids.empty());
  EXPECT_NE(candidate(selection, 1).rejection.find("deg > 30"), std::string::npos)
      << candidate(selection, 1).rejection;
}

TEST(SourceSelection, LimitTiesAndOrderIndependence) {
  const Keyframe target = makeTarget();
  std::vector<Keyframe> keyframes = {
      makeKeyframe(11, poseAt(Eigen::Vector3d(0.4, 0, 0))),
      makeKeyframe(10, poseAt(Eigen::Vector3d(0.4, 0, 0))),  // same pose: same score
      makeKeyframe(12, poseAt(Eigen::Vector3d(-0.4, 0, 0))),
      makeKeyframe(13, poseAt(Eigen::Vector3d(0.2, 0, 0))),
      makeKeyframe(0, poseAt(Eigen::Vector3d(9, 9, 9))),  // the target's id: ignored
  };
  SourceSelectionOptions options;
  options.max_sources = 3;
  const SourceSelection selection = selectSources(target, pointers(keyframes), options);
  EXPECT_EQ(selection.source_ids, (std::vector<int64_t>{10, 11, 12}));
  EXPECT_EQ(candidate(selection, 10).score, candidate(selection, 11).score);
  EXPECT_EQ(candidate(selection, 13).rejection, "rank 4 of 4: only 3 sources are kept");
  EXPECT_EQ(selection.candidates.size(), 4u);

  std::reverse(keyframes.begin(), keyframes.end());
  const SourceSelection again = selectSources(target, pointers(keyframes), options);
  EXPECT_EQ(again.source_ids, selection.source_ids);
  for (size_t i = 0; i < again.candidates.size(); ++i) {
    EXPECT_EQ(again.candidates[i].id, selection.candidates[i].id);
    EXPECT_EQ(again.candidates[i].score, selection.candidates[i].score);
  }
}

TEST(SourceSelection, NoCandidatesGivesEmptyResultWithReason) {
  const SourceSelection selection = selectSources(makeTarget(5), {});
  EXPECT_TRUE(selection.source_ids.empty());
  EXPECT_TRUE(selection.candidates.empty());
  EXPECT_EQ(selection.reason, "keyframe 5: no candidate keyframes to choose sources from");
}

TEST(SourceSelection, FromStore) {
  KeyframeStore store;
  store.add(makeTarget(0));
  store.add(makeKeyframe(1, poseAt(Eigen::Vector3d(0.4, 0, 0))));
  store.add(makeKeyframe(2, poseAt(Eigen::Vector3d(0, 0, 0), 20)));
  const SourceSelection selection = selectSources(store, 0);
  EXPECT_EQ(selection.source_ids, std::vector<int64_t>{1});
  EXPECT_EQ(selection.candidates.size(), 2u);
  // A loop closure that moves keyframe 1 onto the target's position.
  store.updatePose(1, Eigen::Isometry3d::Identity());
  EXPECT_TRUE(selectSources(store, 0).source_ids.empty());
  EXPECT_INPUT_ERROR(selectSources(store, 99), "keyframe 99", "unknown id");
}

TEST(SourceSelection, BadInputIsAClearError) {
  Keyframe target = makeTarget(3);
  const Keyframe other = makeKeyframe(1, poseAt(Eigen::Vector3d(0.4, 0, 0)));
  SourceSelectionOptions options;
  options.max_sources = 0;
  EXPECT_INPUT_ERROR(selectSources(target, {&other}, options), "max_sources", "must be");
  options = SourceSelectionOptions();
  options.min_overlap = std::numeric_limits<double>::quiet_NaN();
  EXPECT_INPUT_ERROR(selectSources(target, {&other}, options), "min_overlap", "must be");

  EXPECT_INPUT_ERROR(selectSources(target, {nullptr}), "keyframe 3", "null candidate");

  target.camera.R *= 2;
  EXPECT_INPUT_ERROR(selectSources(target, {&other}), "keyframe 3", "not rigid");
  target = makeTarget(3);
  target.camera.t.z() = std::numeric_limits<double>::infinity();
  EXPECT_INPUT_ERROR(selectSources(target, {&other}), "keyframe 3", "non-finite");

  // An invalid candidate is rejected with its reason, not thrown.
  Keyframe broken = other;
  broken.id = 4;
  broken.camera.fx = -1;
  const SourceSelection selection = selectSources(makeTarget(3), {&other, &broken});
  EXPECT_EQ(selection.source_ids, std::vector<int64_t>{1});
  EXPECT_EQ(candidate(selection, 4).rejection.rfind("invalid camera: focal", 0), 0u);
}

}  // namespace
}  // namespace amhmvs
