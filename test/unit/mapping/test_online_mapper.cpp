// The online mapping pipeline (online_mapper.h) with an injected estimator
// that returns the exact depth of a wall, so that sources, fusion, the map
// and loop-closure re-posing can be checked against exact numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

using test::kWallZ;
using test::keyframeAt;
using test::wallDepth;
using test::wallOptions;

// Ids of the keyframes a result fused.
std::vector<int64_t> fusedIds(const KeyframeResult& result) {
  std::vector<int64_t> ids;
  for (const FusedKeyframe& fused : result.fused) ids.push_back(fused.id);
  return ids;
}

TEST(OnlineMapper, FirstKeyframeIsASourceThenDeferredFusionAndMap) {
  int calls = 0;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    ++calls;
    return wallDepth(problem);
  });
  ASSERT_EQ(mapper.options().fusion.min_consistent_views, 2);
  const KeyframeResult first = mapper.process(keyframeAt(0, 0.0));
  EXPECT_FALSE(first.has_depth);
  EXPECT_FALSE(first.selection.reason.empty());
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(mapper.store().state(0), KeyframeState::kDone);
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  EXPECT_TRUE(mapper.waitingForFusion().empty());  // no depth map: nothing to fuse

  // Keyframe 1: a depth map, but no other depth map to check it against.
  const KeyframeResult second = mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(second.has_depth);
  EXPECT_EQ(second.selection.source_ids, std::vector<int64_t>{0});
  EXPECT_FALSE(second.fused_now);
  EXPECT_TRUE(second.fused.empty());
  EXPECT_EQ(second.waiting_for_fusion, 1u);
  EXPECT_EQ(mapper.waitingForFusion(), std::vector<int64_t>{1});

  // Keyframe 2: keyframes 1 and 2 each have ONE other depth map, fewer than
  // min_consistent_views (2): neither is fused (no cap to the views there are).
  const KeyframeResult third = mapper.process(keyframeAt(2, 1.0));
  ASSERT_TRUE(third.has_depth);
  EXPECT_FALSE(third.fused_now);
  EXPECT_TRUE(third.fused.empty());
  EXPECT_EQ(mapper.waitingForFusion(), (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  EXPECT_EQ(mapper.mapRevision(), 0u);

  // Keyframe 3: now each has two: 1 is fused via the LATER keyframes 2 and 3,
  // then 2 and 3, oldest first.
  const KeyframeResult fourth = mapper.process(keyframeAt(3, 1.5));
  ASSERT_TRUE(fourth.has_depth);
  EXPECT_TRUE(fourth.fused_now);
  EXPECT_EQ(fusedIds(fourth), (std::vector<int64_t>{1, 2, 3}));
  EXPECT_EQ(fourth.fused[0].consistency_ids.size(), 2u);
  EXPECT_EQ(std::set<int64_t>(fourth.fused[0].consistency_ids.begin(), fourth.fused[0].consistency_ids.end()),
            (std::set<int64_t>{2, 3}));
  EXPECT_TRUE(mapper.waitingForFusion().empty());
  EXPECT_EQ(fourth.waiting_for_fusion, 0u);
  EXPECT_EQ(calls, 3);
  for (const FusedKeyframe& fused : fourth.fused) {
    ASSERT_FALSE(fused.points->empty());
    EXPECT_TRUE(mapper.map().contains(fused.id));
    for (const KeyframePoint& point : *fused.points)
      EXPECT_NEAR(point.position.z() + cameraToWorld(fused.camera).translation().z(), kWallZ, 1e-4);
  }
  const PointCloud cloud = mapper.map().exportCloud();
  ASSERT_GT(cloud.size(), 0u);
  for (const Eigen::Vector3f& p : cloud.points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
  EXPECT_EQ(mapper.mapRevision(), 3u);

  // Keyframe 4 fuses only itself (against its 3 earlier keyframes).
  const KeyframeResult fifth = mapper.process(keyframeAt(4, 2.0));
  EXPECT_EQ(fusedIds(fifth), std::vector<int64_t>{4});
  EXPECT_EQ(mapper.mapRevision(), 4u);
  // Keyframes 1-3, fused with 2 views (the confidence counts up to 4; with 2
  // nothing reaches the default level), are fused again with the 3 they have
  // now, one per fuseAgain() call (the pipeline's idle work), oldest first.
  for (int64_t id = 1; id <= 3; ++id) {
    KeyframeResult again;
    ASSERT_TRUE(mapper.fuseAgain(&again)) << id;
    EXPECT_TRUE(again.fused_again);
    EXPECT_FALSE(again.has_depth);
    EXPECT_EQ(again.id, id);
    ASSERT_EQ(fusedIds(again), std::vector<int64_t>{id});
    EXPECT_TRUE(again.fused[0].again);
    EXPECT_EQ(again.fused[0].consistency_ids.size(), 3u);
    EXPECT_TRUE(mapper.map().contains(id));
  }
  KeyframeResult none;
  EXPECT_FALSE(mapper.fuseAgain(&none));  // nobody has more views now
  EXPECT_EQ(mapper.mapRevision(), 7u);
}

// The first keyframes are fused once two views see them, when no evidence
// reaches the default confidence level (the table's best with 2 views is
// 0.899): they publish nothing then, and everything once a third view is
// there and they are fused again. Off, they keep their first fusion.
TEST(OnlineMapper, FirstKeyframesArePublishedAgainWhenMoreViewsSeeThem) {
  for (const bool again : {true, false}) {
    OnlineMapperOptions options = wallOptions();
    options.confidence.again_with_more_views = again;
    OnlineMapper mapper(options, wallDepth);
    std::map<int64_t, size_t> published;  // keyframe -> published pixels of its latest fusion
    std::map<int64_t, int> fusions;
    const auto note = [&](const KeyframeResult& result) {
      for (const FusedKeyframe& fused : result.fused) {
        published[fused.id] = std::count_if(fused.published.depth.data.begin(), fused.published.depth.data.end(),
                                            [](float d) { return std::isfinite(d); });
        ++fusions[fused.id];
        if (fused.consistency_ids.size() == 2) EXPECT_EQ(published[fused.id], 0u) << fused.id;
      }
    };
    for (int64_t id = 0; id < 5; ++id) note(mapper.process(keyframeAt(id, 0.5 * id)));
    KeyframeResult later;
    while (mapper.fuseAgain(&later)) note(later);
    for (int64_t id = 1; id <= 3; ++id) {
      EXPECT_EQ(fusions[id], again ? 2 : 1) << id;
      if (again) {
        EXPECT_GT(published[id], 0u) << id;
      } else {
        EXPECT_EQ(published[id], 0u) << id;
      }
    }
    EXPECT_EQ(fusions[4], 1);
    EXPECT_GT(published[4], 0u);
  }
}

// With the confidence off the first keyframes are fused again all the same:
// more views confirm more of a depth map (here the wall's pixels that only
// the later keyframes see), so the map does not depend on whether the later
// keyframes were estimated before a keyframe was first fused.
TEST(OnlineMapper, FirstKeyframesAreFusedAgainWithTheConfidenceOff) {
  OnlineMapperOptions options = wallOptions();
  options.confidence.enabled = false;
  ASSERT_TRUE(options.confidence.again_with_more_views);
  OnlineMapper mapper(options, wallDepth);
  std::map<int64_t, std::vector<size_t>> points;  // keyframe -> fused points of each fusion
  const auto note = [&](const KeyframeResult& result) {
    for (const FusedKeyframe& fused : result.fused) {
      EXPECT_TRUE(fused.published.empty()) << fused.id;
      points[fused.id].push_back(fused.points->size());
    }
  };
  for (int64_t id = 0; id < 5; ++id) note(mapper.process(keyframeAt(id, 0.5 * id)));
  KeyframeResult later;
  while (mapper.fuseAgain(&later)) {
    EXPECT_FALSE(later.has_depth);
    note(later);
  }
  // Keyframe 1's first views (0 and 2) already see what it shows of the
  // wall twice; 2 and 3, first fused with views on one side, gain the pixels
  // that only views on the other side see; 4, the last, has earlier ones only.
  EXPECT_EQ(points[1], (std::vector<size_t>{624, 624}));
  EXPECT_EQ(points[2], (std::vector<size_t>{624, 696}));
  EXPECT_EQ(points[3], (std::vector<size_t>{624, 696}));
  EXPECT_EQ(points[4], std::vector<size_t>{624});
  for (int64_t id = 1; id <= 4; ++id) EXPECT_TRUE(mapper.map().contains(id)) << id;
}

// With the confidence on (the default) a fused keyframe carries its depth map
// as published: every exact wall pixel agrees with every consistency view
// that sees it, so its confidence is the table's (seen, seen) value, and the
// depth is NaN exactly where that is below the level; off: nothing.
TEST(OnlineMapper, FusedKeyframesCarryTheirConfidenceAndPublishedDepth) {
  for (const float level : {0.0f, 0.5f, 1.0f}) {
    OnlineMapperOptions options = wallOptions();
    ASSERT_TRUE(options.confidence.enabled);
    options.confidence.min_probability = level;
    OnlineMapper mapper(options, wallDepth);
    size_t published = 0;
    for (int64_t id = 0; id < 5; ++id) {
      const KeyframeResult result = mapper.process(keyframeAt(id, 0.5 * id));
      for (const FusedKeyframe& fused : result.fused) {
        ASSERT_FALSE(fused.published.empty());
        ++published;
        const ImageF& depth = mapper.store().entry(fused.id).depth->depth;
        const PublishedDepth& p = fused.published;
        EXPECT_EQ(p.min_probability, level);
        for (size_t i = 0; i < depth.data.size(); ++i) {
          const int seen = p.counts.seen.data[i];
          EXPECT_EQ(p.counts.agreeing.data[i], seen) << i;
          EXPECT_EQ(p.confidence.data[i], defaultConfidenceCalibration().lookup(seen, seen, 0.1f)) << i;
          if (p.confidence.data[i] < level) {
            EXPECT_TRUE(std::isnan(p.depth.data[i])) << i;
          } else {
            EXPECT_EQ(p.depth.data[i], depth.data[i]) << i;
          }
        }
      }
    }
    EXPECT_EQ(published, 4u);  // keyframes 1-4 (0 waits for its late depth map)
  }
  OnlineMapperOptions off = wallOptions();
  off.confidence.enabled = false;
  OnlineMapper mapper(off, wallDepth);
  for (int64_t id = 0; id < 5; ++id) {
    for (const FusedKeyframe& fused : mapper.process(keyframeAt(id, 0.5 * id)).fused)
      EXPECT_TRUE(fused.published.empty());
  }
}

// The confidence comes from the injected publish function (the pipeline's
// fuser: the GPU's kernel when it fuses there), once per fused keyframe.
TEST(OnlineMapper, ConfidenceComesFromTheInjectedPublishFunction) {
  int calls = 0;
  const PublishFunction publish = [&calls](const FusionView& reference, const std::vector<FusionView>& views,
                                           const ConfidenceOptions& options,
                                           const ConfidenceCalibration& calibration) {
    ++calls;
    return publishDepth(reference, views, options, calibration);
  };
  OnlineMapper mapper(wallOptions(), wallDepth, FuseFunction(), publish);
  OnlineMapper reference_mapper(wallOptions(), wallDepth);
  size_t fused_count = 0;
  for (int64_t id = 0; id < 5; ++id) {
    const KeyframeResult result = mapper.process(keyframeAt(id, 0.5 * id));
    const KeyframeResult expected = reference_mapper.process(keyframeAt(id, 0.5 * id));
    ASSERT_EQ(result.fused.size(), expected.fused.size());
    for (size_t k = 0; k < result.fused.size(); ++k) {
      EXPECT_EQ(result.fused[k].published.counts.agreeing.data, expected.fused[k].published.counts.agreeing.data);
      EXPECT_EQ(result.fused[k].published.confidence.data, expected.fused[k].published.confidence.data);
    }
    fused_count += result.fused.size();
  }
  EXPECT_EQ(calls, static_cast<int>(fused_count));
  EXPECT_EQ(fused_count, 4u);
}

// One buffer per keyframe: the depth map of a result is the store's, and its
// fused points are the store's and the map's (no copies on the way).
TEST(OnlineMapper, ResultsShareTheirDepthMapAndPointsWithTheStoreAndTheMap) {
  OnlineMapper mapper(wallOptions(), [](const DepthProblem& problem) { return wallDepth(problem); });
  for (int i = 0; i < 3; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  const KeyframeResult result = mapper.process(keyframeAt(3, 1.5));
  ASSERT_TRUE(result.has_depth);
  EXPECT_TRUE(result.depth.sameValue(mapper.store().entry(3).depth));
  ASSERT_FALSE(result.fused.empty());
  for (const FusedKeyframe& fused : result.fused) {
    ASSERT_FALSE(fused.points->empty());
    EXPECT_TRUE(fused.points.sameValue(mapper.store().entry(fused.id).points)) << fused.id;
    EXPECT_TRUE(fused.points.sameValue(mapper.map().keyframePoints(fused.id))) << fused.id;
  }
}

TEST(OnlineMapper, KeyframeWithoutSourceGetsItsDepthMapOnceALaterKeyframeQualifies) {
  int calls = 0;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    ++calls;
    return wallDepth(problem);
  });
  KeyframeResult late;
  mapper.process(keyframeAt(0, 0.0));
  EXPECT_EQ(mapper.waitingForSources(), std::vector<int64_t>{0});
  EXPECT_FALSE(mapper.estimateLate(&late));  // still nothing to pair it with
  EXPECT_EQ(late.id, 0);
  EXPECT_FALSE(late.has_depth);

  const KeyframeResult second = mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(second.has_depth);
  EXPECT_EQ(mapper.waitingForSources(), std::vector<int64_t>{0});  // process() never estimates late

  ASSERT_TRUE(mapper.estimateLate(&late));
  EXPECT_EQ(late.id, 0);
  EXPECT_TRUE(late.late);
  ASSERT_TRUE(late.has_depth);
  EXPECT_EQ(late.selection.source_ids, std::vector<int64_t>{1});  // the LATER keyframe
  EXPECT_NEAR(cameraToWorld(late.camera).translation().x(), 0.0, 1e-12);
  EXPECT_FLOAT_EQ(late.depth->depth.at(3, 2), static_cast<float>(kWallZ));
  EXPECT_EQ(mapper.store().entry(0).depth->normal.channels, 3);
  EXPECT_TRUE(mapper.waitingForSources().empty());
  EXPECT_EQ(mapper.waitingForFusion(), (std::vector<int64_t>{1, 0}));
  EXPECT_TRUE(late.fused.empty());  // each has one other depth map, 2 are required
  EXPECT_FALSE(mapper.estimateLate(&late));
  EXPECT_EQ(calls, 2);

  // Keyframe 2 completes all three at once (without the late depth map of 0,
  // keyframe 1 would wait for keyframe 3).
  const KeyframeResult third = mapper.process(keyframeAt(2, 1.0));
  EXPECT_EQ(fusedIds(third), (std::vector<int64_t>{1, 0, 2}));
  EXPECT_TRUE(mapper.map().contains(0));
  for (const Eigen::Vector3f& p : mapper.map().exportCloud().points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
}

TEST(OnlineMapper, SourceViewServesLaterKeyframesAndNeverGetsADepthMap) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  EXPECT_TRUE(mapper.addSourceView(keyframeAt(0, 0.0)).empty());
  const KeyframeResult result = mapper.process(keyframeAt(1, 0.5));
  EXPECT_TRUE(result.has_depth);
  EXPECT_EQ(result.selection.source_ids, std::vector<int64_t>{0});
  EXPECT_TRUE(mapper.waitingForSources().empty());
  KeyframeResult late;
  EXPECT_FALSE(mapper.estimateLate(&late));
  EXPECT_FALSE(mapper.refine(&late));
  const ImageF& depth = mapper.store().entry(0).depth->depth;
  EXPECT_TRUE(std::all_of(depth.data.begin(), depth.data.end(), [](float d) { return std::isnan(d); }));
  EXPECT_THROW(mapper.addSourceView(keyframeAt(0, 1.0)), InputError);  // duplicate id
}

TEST(OnlineMapper, KeyframeThatNeverGetsASourceIsCountedWhenEvicted) {
  OnlineMapperOptions options = wallOptions();
  options.store.max_keyframes = 2;
  OnlineMapper mapper(options, wallDepth);
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 20.0));  // far from 0: no source either
  EXPECT_EQ(mapper.waitingForSources(), (std::vector<int64_t>{0, 1}));
  KeyframeResult late;
  EXPECT_FALSE(mapper.estimateLate(&late));
  const KeyframeResult third = mapper.process(keyframeAt(2, 20.5));  // evicts 0
  EXPECT_EQ(third.evicted, std::vector<int64_t>{0});
  EXPECT_EQ(mapper.evictedWithoutDepth(), 1u);
  EXPECT_EQ(mapper.waitingForSources(), std::vector<int64_t>{1});
  ASSERT_TRUE(mapper.estimateLate(&late));
  EXPECT_EQ(late.id, 1);
  mapper.reset();
  EXPECT_TRUE(mapper.waitingForSources().empty());
  EXPECT_EQ(mapper.evictedWithoutDepth(), 0u);
}

TEST(OnlineMapper, FailedLateEstimateKeepsTheKeyframeAsASourceOnly) {
  bool fail = false;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    if (fail) throw BackendError("injected: device lost");
    return wallDepth(problem);
  });
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 0.5));
  fail = true;
  KeyframeResult late;
  EXPECT_THROW(mapper.estimateLate(&late), BackendError);
  EXPECT_EQ(late.id, 0);  // says which keyframe failed
  EXPECT_TRUE(mapper.store().contains(0));  // still a source of keyframe 1
  EXPECT_TRUE(mapper.waitingForSources().empty());  // not retried
  fail = false;
  EXPECT_FALSE(mapper.estimateLate(&late));
  EXPECT_EQ(mapper.waitingForFusion(), std::vector<int64_t>{1});
}

// Sorted source ids of a result.
std::vector<int64_t> sortedSources(const KeyframeResult& result) {
  std::vector<int64_t> ids = result.selection.source_ids;
  std::sort(ids.begin(), ids.end());
  return ids;
}

TEST(OnlineMapper, RefineChoosesAnewNearTheNewestKeyframeFirstAndReachesTheRestLater) {
  // 30 keyframes along the wall, none refined meanwhile: each was estimated
  // with earlier keyframes only, so each gains from its successors.
  OnlineMapper mapper(wallOptions(), wallDepth);
  KeyframeResult result;
  constexpr int kCount = 30;
  for (int i = 0; i < kCount; ++i) {
    mapper.process(keyframeAt(i, 0.5 * i));
    if (i == 1) ASSERT_TRUE(mapper.estimateLate(&result));
  }
  // The first call looks only at the 16 keyframes nearest the newest (14..29).
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_TRUE(result.refined);
  EXPECT_GE(result.id, kCount - OnlineMapper::kSelectionsPerRefineCall);
  // Further calls reach the far end too.
  std::set<int64_t> refined = {result.id};
  for (int call = 0; call < 200; ++call) {
    KeyframeResult next;
    if (mapper.refine(&next) && next.refined) refined.insert(next.id);
  }
  EXPECT_TRUE(refined.count(0)) << "keyframe 0 never refined";
  EXPECT_TRUE(refined.count(1)) << "keyframe 1 never refined";
}

TEST(OnlineMapper, RefineReestimatesAKeyframeOnceWhenLaterKeyframesGiveBetterSources) {
  std::vector<size_t> source_counts;  // per estimate call
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    source_counts.push_back(problem.source_cameras.size());
    return wallDepth(problem);
  });
  KeyframeResult result;
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(mapper.estimateLate(&result));  // keyframe 0 with {1}
  EXPECT_FALSE(mapper.refine(&result)) << result.id;  // nothing better yet
  mapper.process(keyframeAt(2, 1.0));           // fuses 1, 0, 2
  ASSERT_TRUE(mapper.map().contains(0));

  // Keyframe 0 (estimated with {1}) now has {1, 2}: re-estimated and fused again.
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_EQ(result.id, 0);
  EXPECT_TRUE(result.refined);
  EXPECT_FALSE(result.late);
  ASSERT_TRUE(result.has_depth);
  EXPECT_EQ(sortedSources(result), (std::vector<int64_t>{1, 2}));
  ASSERT_EQ(fusedIds(result), std::vector<int64_t>{0});
  EXPECT_TRUE(result.fused[0].again);
  EXPECT_EQ(source_counts.back(), 2u);
  // Then keyframe 1 ({0} -> {0, 2}); keyframe 2 was estimated with {0, 1} and
  // has nothing new.
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_EQ(result.id, 1);
  EXPECT_EQ(sortedSources(result), (std::vector<int64_t>{0, 2}));
  EXPECT_FALSE(mapper.refine(&result));
  EXPECT_EQ(source_counts.size(), 5u);  // 3 first estimates + 2 refinements

  // Keyframe 3 gives keyframe 2 a third source; 0 and 1 are refined at most once.
  mapper.process(keyframeAt(3, 1.5));
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_EQ(result.id, 2);
  EXPECT_EQ(sortedSources(result), (std::vector<int64_t>{0, 1, 3}));
  EXPECT_FALSE(mapper.refine(&result));
  // Re-fusion replaced points, never added copies: the map is still the wall.
  for (const Eigen::Vector3f& p : mapper.map().exportCloud().points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
  size_t points = 0;
  for (int64_t id : mapper.map().keyframeIds()) points += mapper.store().entry(id).points->size();
  EXPECT_EQ(mapper.map().storedPointCount(), points);
}

TEST(OnlineMapper, RefinementWorseByTheEstimatorsEvidenceIsRejectedAndABetterOneKept) {
  OnlineMapperOptions options = wallOptions();
  options.refinement.keep_only_better = true;
  OnlineMapper mapper(options, test::wallDepthWithABadRefinementOfKeyframe0);
  KeyframeResult result;
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(mapper.estimateLate(&result));
  mapper.process(keyframeAt(2, 1.0));
  const size_t map_points = mapper.map().storedPointCount();
  // Keyframe 0 with {1, 2}: the bad sources' map (4 m, cost 0.9) is dropped.
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_EQ(result.id, 0);
  EXPECT_TRUE(result.refinement_rejected);
  EXPECT_NE(result.refinement_evidence.find("confident pixels 768 -> 0, median cost 0.1 -> 0.9"), std::string::npos)
      << result.refinement_evidence;
  EXPECT_TRUE(result.fused.empty());
  EXPECT_FLOAT_EQ(mapper.store().entry(0).depth->depth.at(3, 3), static_cast<float>(kWallZ));
  EXPECT_FLOAT_EQ(mapper.store().entry(0).depth->cost.at(3, 3), 0.1f);
  EXPECT_EQ(mapper.map().storedPointCount(), map_points);
  for (const Eigen::Vector3f& p : mapper.map().exportCloud().points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
  // Keyframe 1 with {0, 2}: lower cost everywhere, kept and fused again.
  ASSERT_TRUE(mapper.refine(&result));
  EXPECT_EQ(result.id, 1);
  EXPECT_FALSE(result.refinement_rejected) << result.refinement_evidence;
  EXPECT_FLOAT_EQ(mapper.store().entry(1).depth->cost.at(3, 3), 0.05f);
  ASSERT_EQ(fusedIds(result), std::vector<int64_t>{1});
  // The rejected selection is not tried again.
  EXPECT_FALSE(mapper.refine(&result));

  // Switched off, the bad map replaces the good one (the old behaviour).
  options.refinement.keep_only_better = false;  // the default
  OnlineMapper always(options, test::wallDepthWithABadRefinementOfKeyframe0);
  always.process(keyframeAt(0, 0.0));
  always.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(always.estimateLate(&result));
  always.process(keyframeAt(2, 1.0));
  ASSERT_TRUE(always.refine(&result));
  EXPECT_FALSE(result.refinement_rejected);
  EXPECT_FLOAT_EQ(always.store().entry(0).depth->depth.at(3, 3), 4.0f);
}

TEST(OnlineMapper, RefinementCanBeSwitchedOffAndItsOptionsAreChecked) {
  OnlineMapperOptions options = wallOptions();
  options.refinement.max_refinements = 0;
  OnlineMapper mapper(options, wallDepth);
  KeyframeResult result;
  for (int i = 0; i < 4; ++i) {
    mapper.process(keyframeAt(i, 0.5 * i));
    mapper.estimateLate(&result);
  }
  EXPECT_FALSE(mapper.refine(&result));
  options.refinement.min_score_gain = 1.0;  // would re-estimate for no gain
  EXPECT_NE(options.validate().find("refinement: min_score_gain must be finite and > 1"), std::string::npos)
      << options.validate();
  options.refinement.min_score_gain = 1.5;
  options.refinement.max_refinements = -1;
  EXPECT_THROW(OnlineMapper(options, wallDepth), InputError);
  options.refinement.max_refinements = 1;
  options.refinement.confident_cost = -0.1;
  options.refinement.max_confident_loss = 1;
  EXPECT_NE(options.validate().find("refinement: confident_cost must be >= 0"), std::string::npos)
      << options.validate();
  EXPECT_NE(options.validate().find("refinement: max_confident_loss must be in [0, 1)"), std::string::npos)
      << options.validate();
}

// The estimator's depth with a blob: cameras with x in [blob_min_x,
// blob_max_x] see a false surface at z = 4 where it covers x in [0.2, 0.8],
// |y| <= 0.3 (world), a correlated outlier that two views agree on.
DepthMap wallWithBlob(const DepthProblem& problem, double blob_min_x, double blob_max_x) {
  DepthMap map = wallDepth(problem);
  const PinholeCamera& camera = problem.reference_camera;
  const Eigen::Vector3d centre = cameraToWorld(camera).translation();
  if (centre.x() < blob_min_x - 1e-9 || centre.x() > blob_max_x + 1e-9) return map;
  const double depth = 4.0 - centre.z();
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const double wx = centre.x() + depth * (x - camera.cx) / camera.fx;
      const double wy = centre.y() + depth * (y - camera.cy) / camera.fy;
      if (wx >= 0.2 && wx <= 0.8 && std::abs(wy) <= 0.3) map.depth.at(x, y) = static_cast<float>(depth);
    }
  }
  return map;
}

size_t pointsNearerThan(const PointCloud& cloud, double z) {
  size_t count = 0;
  for (const Eigen::Vector3f& p : cloud.points) count += p.z() < z;
  return count;
}

// The wall's exact depth, except keyframe 1's (at x = 0.5) first depth map,
// all NaN: it confirms nothing.
EstimateFunction wallWhoseKeyframe1FirstConfirmsNothing() {
  auto first_estimates_of_1 = std::make_shared<int>(0);
  return [first_estimates_of_1](const DepthProblem& problem) {
    DepthMap map = wallDepth(problem);
    const bool keyframe_1 = std::abs(cameraToWorld(problem.reference_camera).translation().x() - 0.5) < 1e-9;
    if (keyframe_1 && (*first_estimates_of_1)++ == 0)
      std::fill(map.depth.data.begin(), map.depth.data.end(), std::numeric_limits<float>::quiet_NaN());
    return map;
  };
}

TEST(OnlineMapper, KeyframeFusedFirstWithoutPointsIsFusedAgainWhenRefined) {
  OnlineMapperOptions options = wallOptions();
  options.refinement.min_score_gain = 1.01;
  OnlineMapper mapper(options, wallWhoseKeyframe1FirstConfirmsNothing());
  std::vector<FusedKeyframe> fusions_of_1;
  const auto keep = [&](const KeyframeResult& result) {
    for (const FusedKeyframe& fused : result.fused)
      if (fused.id == 1) fusions_of_1.push_back(fused);
  };
  for (int i = 0; i < 3; ++i) {
    keep(mapper.process(keyframeAt(i, 0.5 * i)));
    KeyframeResult late;
    if (mapper.estimateLate(&late)) keep(late);
  }
  ASSERT_EQ(fusions_of_1.size(), 1u);
  EXPECT_FALSE(fusions_of_1[0].again);
  EXPECT_TRUE(fusions_of_1[0].points->empty());
  EXPECT_FALSE(mapper.map().contains(1));
  KeyframeResult refined;
  while (mapper.refine(&refined)) keep(refined);
  ASSERT_EQ(fusions_of_1.size(), 2u);
  EXPECT_TRUE(fusions_of_1[1].again);  // a second fusion, though the first left no point
  EXPECT_FALSE(fusions_of_1[1].points->empty());
  EXPECT_TRUE(mapper.map().contains(1));
}

// Keyframe 2 is fused against {0, 1} while 1's first depth map confirms
// nothing, so it gets no point; the refinements then replace 0's and 1's
// depth maps. With refinement.fuse_neighbours_again keyframe 2 is fused
// again against them (once, after the refinements) and reaches the map;
// without, it keeps its empty fusion.
TEST(OnlineMapper, KeyframeFusedAgainstAReplacedDepthMapIsFusedAgainWhenAsked) {
  for (const bool again : {false, true}) {
    OnlineMapperOptions options = wallOptions();
    options.refinement.min_score_gain = 1.01;
    options.refinement.fuse_neighbours_again = again;
    OnlineMapper mapper(options, wallWhoseKeyframe1FirstConfirmsNothing());
    std::vector<FusedKeyframe> fusions_of_2;
    std::vector<bool> refined_before;  // per fusion of 2: a refinement ran before it in the same call
    const auto keep = [&](const KeyframeResult& result) {
      for (const FusedKeyframe& fused : result.fused) {
        if (fused.id != 2) continue;
        fusions_of_2.push_back(fused);
        refined_before.push_back(result.refined);
      }
    };
    for (int i = 0; i < 3; ++i) {
      keep(mapper.process(keyframeAt(i, 0.5 * i)));
      KeyframeResult late;
      if (mapper.estimateLate(&late)) keep(late);
    }
    ASSERT_EQ(fusions_of_2.size(), 1u) << again;
    EXPECT_EQ(fusions_of_2[0].consistency_ids, (std::vector<int64_t>{1, 0}));
    EXPECT_TRUE(fusions_of_2[0].points->empty());
    int refinements = 0;
    KeyframeResult step;
    while (mapper.refine(&step)) {
      refinements += step.refined;
      keep(step);
    }
    EXPECT_EQ(refinements, 2) << again;  // 0 and 1
    if (!again) {
      EXPECT_EQ(fusions_of_2.size(), 1u);
      EXPECT_FALSE(mapper.map().contains(2));
      continue;
    }
    ASSERT_EQ(fusions_of_2.size(), 2u);  // once, though both its views were replaced
    EXPECT_TRUE(fusions_of_2[1].again);
    EXPECT_FALSE(refined_before[1]);  // its own step, not a refinement's
    EXPECT_FALSE(fusions_of_2[1].points->empty());
    EXPECT_TRUE(mapper.map().contains(2));
    for (const Eigen::Vector3f& p : mapper.map().exportCloud().points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
  }
}

TEST(OnlineMapper, OutlierThatOnlyOneViewChecksNeverReachesTheMap) {
  // Keyframes 1 and 2 (x = 0.5, 1.0) share the blob; 3 and 4 see the wall.
  const auto estimate = [](const DepthProblem& problem) { return wallWithBlob(problem, 0.5, 1.0); };
  {
    // Control: with one consistent view required, the blob (each of 1 and 2
    // confirmed by the other) reaches the map, so the test can see it.
    OnlineMapperOptions options = wallOptions();
    options.fusion.min_consistent_views = 1;
    OnlineMapper mapper(options, estimate);
    for (int i = 0; i < 5; ++i) mapper.process(keyframeAt(i, 0.5 * i));
    EXPECT_GT(pointsNearerThan(mapper.map().exportCloud(), 4.5), 0u);
  }
  OnlineMapper mapper(wallOptions(), estimate);  // min_consistent_views 2
  for (int i = 0; i < 5; ++i) {
    mapper.process(keyframeAt(i, 0.5 * i));
    EXPECT_EQ(pointsNearerThan(mapper.map().exportCloud(), 4.5), 0u) << "after keyframe " << i;
  }
  EXPECT_TRUE(mapper.map().contains(1));
  EXPECT_TRUE(mapper.map().contains(2));
  const PointCloud cloud = mapper.map().exportCloud();
  ASSERT_GT(cloud.size(), 0u);
  for (const Eigen::Vector3f& p : cloud.points) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
}

TEST(OnlineMapper, WaitingKeyframeIsFusedWithItsLoopClosedPose) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 3; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  ASSERT_EQ(mapper.waitingForFusion(), (std::vector<int64_t>{1, 2}));
  // Moved within the wall's plane, so the depth map stays exact.
  EXPECT_TRUE(mapper.updatePose(1, test::poseAt({0.5, 0.4, 0})));
  EXPECT_FALSE(mapper.map().contains(1));
  EXPECT_EQ(mapper.mapRevision(), 0u);
  const KeyframeResult result = mapper.process(keyframeAt(3, 1.5));
  ASSERT_EQ(fusedIds(result), (std::vector<int64_t>{1, 2, 3}));
  EXPECT_NEAR(cameraToWorld(result.fused[0].camera).translation().y(), 0.4, 1e-12);
  EXPECT_NEAR(mapper.map().pose(1).translation().y(), 0.4, 1e-12);
}

TEST(OnlineMapper, WaitingKeyframeEvictedBeforeFusionIsCounted) {
  OnlineMapperOptions options = wallOptions();
  options.store.max_keyframes = 2;
  OnlineMapper mapper(options, wallDepth);
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 0.5));
  const KeyframeResult third = mapper.process(keyframeAt(2, 1.0));  // evicts 0 (no depth map)
  EXPECT_EQ(third.evicted, std::vector<int64_t>{0});
  EXPECT_TRUE(third.evicted_before_fusion.empty());
  EXPECT_EQ(mapper.waitingForFusion(), (std::vector<int64_t>{1, 2}));
  const KeyframeResult fourth = mapper.process(keyframeAt(3, 1.5));  // evicts 1, still waiting
  EXPECT_EQ(fourth.evicted, std::vector<int64_t>{1});
  EXPECT_EQ(fourth.evicted_before_fusion, std::vector<int64_t>{1});
  EXPECT_EQ(mapper.evictedBeforeFusion(), 1u);
  EXPECT_EQ(mapper.waitingForFusion(), (std::vector<int64_t>{2, 3}));
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  mapper.reset();
  EXPECT_TRUE(mapper.waitingForFusion().empty());
  EXPECT_EQ(mapper.evictedBeforeFusion(), 0u);
}

TEST(OnlineMapper, LoopClosureMovesTheKeyframesMapPointsExactly) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 4; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  ASSERT_TRUE(mapper.map().contains(2));
  ASSERT_EQ(mapper.mapRevision(), 3u);  // keyframes 1, 2, 3 fused
  const PointCloud before = mapper.map().exportCloud();
  // Keyframe 2 moves 0.4 m up (y): its points move with it.
  EXPECT_TRUE(mapper.updatePose(2, test::poseAt({1.0, 0.4, 0})));
  const PointCloud after = mapper.map().exportCloud();
  // Keyframes 1 and 3 share voxels with 2: compare the sums of all points
  // (voxel mean times count), which only keyframe 2's points change.
  const size_t points = mapper.map().storedPointCount();
  const size_t moved = mapper.store().entry(2).points->size();
  ASSERT_GT(moved, 0u);
  double sum_before = 0, sum_after = 0;
  size_t count_before = 0, count_after = 0;
  for (size_t i = 0; i < before.size(); ++i) {
    sum_before += double(before.points[i].y()) * before.counts[i];
    count_before += before.counts[i];
  }
  for (size_t i = 0; i < after.size(); ++i) {
    sum_after += double(after.points[i].y()) * after.counts[i];
    count_after += after.counts[i];
  }
  EXPECT_EQ(count_before, points);
  EXPECT_EQ(count_after, points);
  EXPECT_NEAR((sum_after - sum_before) / moved, 0.4, 1e-4);
  EXPECT_EQ(mapper.mapRevision(), 4u);
  EXPECT_NEAR(cameraToWorld(mapper.store().keyframe(2).camera).translation().y(), 0.4, 1e-12);
  EXPECT_FALSE(mapper.updatePose(99, test::poseAt({0, 0, 0})));
  Eigen::Isometry3d bad = test::poseAt({0, 0, 0});
  bad.translation().x() = NAN;
  EXPECT_THROW(mapper.updatePose(2, bad), InputError);
}

TEST(OnlineMapper, FailedEstimateLeavesNoPendingKeyframe) {
  bool fail = false;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    if (fail) throw BackendError("injected: out of memory");
    return wallDepth(problem);
  });
  mapper.process(keyframeAt(0, 0.0));
  fail = true;
  EXPECT_THROW(mapper.process(keyframeAt(1, 0.5)), BackendError);
  EXPECT_FALSE(mapper.store().contains(1));
  fail = false;
  EXPECT_TRUE(mapper.process(keyframeAt(2, 0.5)).has_depth);
  EXPECT_THROW(mapper.process(keyframeAt(2, 0.6)), InputError);  // duplicate id
}

// A keyframe whose fusion throws is dropped from everything: no later step
// (a refinement ranks every estimated keyframe) looks it up again.
TEST(OnlineMapper, KeyframeDroppedByAFailedFusionIsNeverLookedUpAgain) {
  int64_t failing = -1;
  const FuseFunction fuse = [&failing](const std::vector<FusionView>& views, const FusionOptions& options) {
    if (failing >= 0) throw InputError("injected: fusion of the newest keyframe fails");
    return fuseDepthMaps(views, options);
  };
  OnlineMapper mapper(wallOptions(), wallDepth, fuse);
  KeyframeResult result;
  mapper.process(keyframeAt(0, 0.0));
  mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(mapper.estimateLate(&result));  // keyframe 0 with {1}: 2 is the first to fuse
  failing = 2;
  EXPECT_THROW(mapper.process(keyframeAt(2, 1.0)), InputError);
  failing = -1;
  EXPECT_FALSE(mapper.store().contains(2));
  for (int64_t id = 3; id < 6; ++id) {
    ASSERT_NO_THROW(mapper.process(keyframeAt(id, 0.5 * id)));
    // Refinements run out (each keyframe at most once) and never name keyframe 2.
    for (int i = 0; i < 10 && mapper.refine(&result); ++i) ASSERT_NE(result.id, 2);
  }
  EXPECT_FALSE(mapper.refine(&result));
  EXPECT_FALSE(mapper.map().contains(2));
}

// A handshake between the estimate (on the mapper's worker thread) and the
// fusion (on the caller's): in a round the test opens, the first fusion waits
// until an estimate is running and that estimate waits until the fusion has
// seen it, so an overlap is proven, not hoped for. Without one, each wait
// ends after 10 s and counts as a miss (the test fails instead of hanging).
struct OverlapProbe {
  std::mutex mutex;
  std::condition_variable changed;
  bool round_open = false, estimating = false, fusion_seen = false;
  int fusions_during_estimates = 0, misses = 0;

  void openRound() {
    std::lock_guard<std::mutex> lock(mutex);
    round_open = true;
  }
  EstimateFunction estimate() {
    return [this](const DepthProblem& problem) {
      std::unique_lock<std::mutex> lock(mutex);
      estimating = true;
      changed.notify_all();
      if (round_open && !changed.wait_for(lock, std::chrono::seconds(10), [this] { return fusion_seen; })) ++misses;
      estimating = false;
      fusion_seen = false;
      return wallDepth(problem);
    };
  }
  FuseFunction fuse() {
    return [this](const std::vector<FusionView>& views, const FusionOptions& options) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        if (round_open) {
          if (changed.wait_for(lock, std::chrono::seconds(10), [this] { return estimating; })) {
            ++fusions_during_estimates;
            fusion_seen = true;
          } else {
            ++misses;
          }
          round_open = false;
          changed.notify_all();
        }
      }
      return fuseDepthMaps(views, options);
    };
  }
};

// Fused points (position, confidence) of every keyframe that `results` fused (the last fusion of each).
std::map<int64_t, std::vector<float>> fusedCoordinates(const std::vector<KeyframeResult>& results) {
  std::map<int64_t, std::vector<float>> points;
  for (const KeyframeResult& result : results)
    for (const FusedKeyframe& fused : result.fused) {
      std::vector<float>& xyz = points[fused.id];
      xyz.clear();
      for (const KeyframePoint& point : *fused.points)
        xyz.insert(xyz.end(), {point.position.x(), point.position.y(), point.position.z(), point.confidence});
    }
  return points;
}

TEST(OnlineMapper, FusionDeferredToTheNextKeyframeRunsDuringItsEstimateWithTheSameResult) {
  OnlineMapper at_once(wallOptions(), wallDepth);
  std::vector<KeyframeResult> expected;
  for (int i = 0; i < 8; ++i) expected.push_back(at_once.process(keyframeAt(i, 0.25 * i)));

  OverlapProbe probe;
  OnlineMapper overlapped(wallOptions(), probe.estimate(), probe.fuse());
  std::vector<KeyframeResult> results;
  for (int i = 0; i < 8; ++i) {
    // Keyframes 1-3 are fused once keyframe 3 has a depth map: from keyframe
    // 4 on, each estimate runs while the keyframe before it is fused.
    if (i >= 4) probe.openRound();
    const bool next_follows = i < 7;
    results.push_back(overlapped.process(keyframeAt(i, 0.25 * i), next_follows));
    EXPECT_EQ(overlapped.fusionDeferred(), next_follows && results.back().has_depth) << i;
  }
  EXPECT_EQ(probe.fusions_during_estimates, 4);
  EXPECT_EQ(probe.misses, 0);
  // Keyframe 3's result fuses nothing: 1, 2 and 3 come with 4's; the last,
  // which no keyframe follows, is fused at once after the one before it.
  EXPECT_EQ(fusedIds(expected[3]), (std::vector<int64_t>{1, 2, 3}));
  EXPECT_TRUE(results[3].fused.empty());
  EXPECT_EQ(fusedIds(results[4]), (std::vector<int64_t>{1, 2, 3}));
  EXPECT_FALSE(results[4].fused_now);
  EXPECT_EQ(fusedIds(results[7]), (std::vector<int64_t>{6, 7}));
  EXPECT_TRUE(results[7].fused_now);
  // The same points and map as fusing each keyframe at once.
  EXPECT_EQ(fusedCoordinates(results), fusedCoordinates(expected));
  EXPECT_FALSE(fusedCoordinates(results).empty());
  EXPECT_EQ(overlapped.map().voxelCount(), at_once.map().voxelCount());
  EXPECT_FALSE(overlapped.fusionDeferred());
}

TEST(OnlineMapper, DeferredFusionRunsAloneWhenNoKeyframeFollowsAndNotAfterAReset) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 5; ++i) mapper.process(keyframeAt(i, 0.25 * i), /*next_follows=*/true);
  ASSERT_TRUE(mapper.fusionDeferred());
  EXPECT_EQ(mapper.waitingForFusion(), std::vector<int64_t>{4});
  // Fusion again runs it as its work (newer work first).
  KeyframeResult result;
  ASSERT_TRUE(mapper.fuseAgain(&result));
  EXPECT_TRUE(result.deferred_fusion);
  EXPECT_FALSE(result.has_depth);
  EXPECT_EQ(result.id, 4);
  EXPECT_EQ(fusedIds(result), std::vector<int64_t>{4});
  EXPECT_FALSE(mapper.fusionDeferred());
  EXPECT_FALSE(mapper.fuseDeferred(&result));

  mapper.process(keyframeAt(5, 1.25), /*next_follows=*/true);
  ASSERT_TRUE(mapper.fuseDeferred(&result));
  EXPECT_EQ(fusedIds(result), std::vector<int64_t>{5});
  EXPECT_TRUE(mapper.map().contains(5));

  mapper.process(keyframeAt(6, 1.5), /*next_follows=*/true);
  mapper.reset();
  EXPECT_FALSE(mapper.fusionDeferred());
  EXPECT_FALSE(mapper.fuseDeferred(&result));
}

// A deferred fusion that ran during an estimate which then failed: its fused
// keyframes come with the next result instead of being lost.
TEST(OnlineMapper, FusionDoneDuringAFailedEstimateIsHandedOutWithTheNextResult) {
  bool fail = false;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    if (fail) throw BackendError("injected: device lost");
    return wallDepth(problem);
  });
  for (int i = 0; i < 5; ++i) mapper.process(keyframeAt(i, 0.25 * i), /*next_follows=*/true);
  fail = true;
  EXPECT_THROW(mapper.process(keyframeAt(5, 1.25), /*next_follows=*/true), BackendError);
  fail = false;
  EXPECT_TRUE(mapper.fusionDeferred());  // undelivered
  EXPECT_TRUE(mapper.waitingForFusion().empty());
  const KeyframeResult next = mapper.process(keyframeAt(6, 1.5));
  EXPECT_EQ(fusedIds(next), (std::vector<int64_t>{4, 6}));
  EXPECT_FALSE(mapper.fusionDeferred());
}

TEST(OnlineMapper, ResetAndVoxelSizeChange) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 4; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  const size_t voxels = mapper.map().voxelCount();
  ASSERT_GT(voxels, 0u);
  OnlineMapperOptions coarser = wallOptions();
  coarser.map.leaf_size = 0.5;
  mapper.setOptions(coarser);
  EXPECT_LT(mapper.map().voxelCount(), voxels);
  EXPECT_GT(mapper.map().voxelCount(), 0u);
  // Fewer voxels published, none dropped, and the map is new to its readers.
  const PointCloud every_voxel = mapper.map().exportCloud();
  const size_t published = every_voxel.size();
  const int most_points = static_cast<int>(*std::max_element(every_voxel.counts.begin(), every_voxel.counts.end()));
  const uint64_t revision = mapper.mapRevision();
  OnlineMapperOptions thick = coarser;
  thick.map.min_points_per_voxel = most_points;  // only the fullest voxels
  mapper.setOptions(thick);
  EXPECT_EQ(mapper.map().options().min_points_per_voxel, most_points);
  EXPECT_LT(mapper.map().exportCloud().size(), published);
  EXPECT_GT(mapper.map().exportCloud().size(), 0u);
  EXPECT_EQ(mapper.map().voxelCount(), published);
  EXPECT_GT(mapper.mapRevision(), revision);
  thick.map.min_points_per_voxel = 0;
  EXPECT_THROW(mapper.setOptions(thick), InputError);
  EXPECT_EQ(mapper.map().options().min_points_per_voxel, most_points);  // nothing changed
  mapper.setOptions(coarser);
  EXPECT_EQ(mapper.map().exportCloud().size(), published);
  coarser.sources.max_sources = 0;
  EXPECT_THROW(mapper.setOptions(coarser), InputError);
  mapper.process(keyframeAt(10, 20.0));  // far away: no source
  mapper.process(keyframeAt(11, 20.5));  // waits: no other depth map there
  EXPECT_FALSE(mapper.waitingForFusion().empty());
  mapper.reset();
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  EXPECT_EQ(mapper.store().size(), 0u);
  EXPECT_TRUE(mapper.waitingForFusion().empty());
}

// The map update in the background (the default) gives the same map, the
// same update records in the same order and the same revisions as in the
// foreground, including re-posing and reset while an update may be running.
TEST(OnlineMapper, MapUpdatesInTheBackgroundGiveTheSameMapAsInTheForeground) {
  struct Run {
    PointCloud cloud;
    std::vector<int64_t> record_ids;
    size_t added = 0;
    uint64_t revision = 0;
    size_t voxels_seen = 0;  // mapVoxelCount() after finishMapWork()
  };
  const auto run = [](bool background) {
    OnlineMapperOptions options = wallOptions();
    options.map_in_background = background;
    OnlineMapper mapper(options, wallDepth);
    Run out;
    for (int i = 0; i < 8; ++i) {
      mapper.process(keyframeAt(i, 0.3 * i));
      if (i == 5) {  // loop closure while the last update may still run
        Eigen::Isometry3d pose = mapper.store().keyframe(3).cameraToWorld();
        pose.translation().y() += 0.01;
        mapper.updatePose(3, pose);
      }
    }
    mapper.finishMapWork();
    out.voxels_seen = mapper.mapVoxelCount();
    for (const MapUpdateRecord& record : mapper.takeMapUpdates()) {
      out.record_ids.push_back(record.id);
      out.added += record.update.added_points;
    }
    out.cloud = mapper.map().exportCloud();
    out.revision = mapper.mapRevision();
    return out;
  };
  const Run foreground = run(false), background = run(true);
  ASSERT_GT(foreground.cloud.size(), 100u);
  EXPECT_EQ(background.record_ids, foreground.record_ids);
  EXPECT_EQ(background.added, foreground.added);
  EXPECT_EQ(background.revision, foreground.revision);
  EXPECT_EQ(background.voxels_seen, foreground.cloud.size());
  ASSERT_EQ(background.cloud.size(), foreground.cloud.size());
  EXPECT_EQ(background.cloud.points, foreground.cloud.points);  // bit for bit
  EXPECT_EQ(background.cloud.counts, foreground.cloud.counts);
}

TEST(OnlineMapper, ResetWhileAMapUpdateRunsEmptiesTheMap) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 5; ++i) mapper.process(keyframeAt(i, 0.3 * i));
  mapper.reset();  // the last fusion's update may still be running
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  EXPECT_EQ(mapper.mapVoxelCount(), 0u);
  EXPECT_TRUE(mapper.takeMapUpdates().empty());
}

}  // namespace
}  // namespace amhmvs

namespace amhmvs {
namespace {

// Step 8 as a schedule (the wall's images are flat: no pixel converges, the
// filter's own accuracy is test_depth_filter.cpp's): each keyframe's filter
// starts with its first depth map, every later keyframe and frame refines the
// newest `keyframes` filters, and a keyframe's depth comes out again every
// publish_every frames and once more when it is final, as fused and published.
TEST(OnlineMapper, TemporalDepthRepublishesEachKeyframeAtItsRateUntilFinal) {
  OnlineMapperOptions options = wallOptions();
  options.depth_filter.enabled = true;
  options.depth_filter.keyframes = 2;
  options.depth_filter.frames_per_keyframe = 3;
  options.depth_filter.publish_every = 2;
  options.confidence.min_probability = 0;  // published at fusion: every estimated pixel
  OnlineMapper mapper(options, wallDepth);
  const auto refined = [](const std::vector<RefinedDepth>& depths) {
    std::vector<std::pair<int64_t, int>> out;
    for (const RefinedDepth& depth : depths) out.push_back({depth.id, depth.frames * (depth.final ? -1 : 1)});
    return out;
  };
  using Published = std::vector<std::pair<int64_t, int>>;  // (id, frames; negative: final)
  EXPECT_TRUE(mapper.process(keyframeAt(0, 0.0)).refined_depths.empty());  // no depth map
  EXPECT_TRUE(mapper.process(keyframeAt(1, 0.5)).refined_depths.empty());  // starts 1
  EXPECT_TRUE(mapper.process(keyframeAt(2, 1.0)).refined_depths.empty());  // 1 has 1 frame; starts 2
  // Keyframe 3: 1's second frame (published), 2's first; 3 starts and 1,
  // the oldest of three, is final without a frame since its publication.
  EXPECT_EQ(refined(mapper.process(keyframeAt(3, 1.5)).refined_depths), (Published{{1, 2}}));
  // A frame between keyframes: 2's second (published), 3's first.
  EXPECT_EQ(refined(mapper.observe(keyframeAt(100, 1.7))), (Published{{2, 2}}));
  // Keyframe 4: 2's third frame makes it final; 3's second is published.
  const KeyframeResult fifth = mapper.process(keyframeAt(4, 2.0));
  EXPECT_EQ(refined(fifth.refined_depths), (Published{{2, -3}, {3, 2}}));
  for (const RefinedDepth& depth : fifth.refined_depths) {
    ASSERT_EQ(depth.published.depth.width, depth.camera.width);
    ASSERT_EQ(depth.published.confidence.width, depth.camera.width);
    size_t finite = 0;
    for (float value : depth.published.depth.data) {
      if (!std::isfinite(value)) continue;
      ++finite;
      EXPECT_NEAR(value, kWallZ, 1e-3);  // the depth as published at fusion
    }
    EXPECT_GT(finite, 0u) << depth.id;
  }
  // Bad frames are refused with the reason; a reset forgets every filter.
  Keyframe bad = keyframeAt(101, 2.1);
  bad.image = ImageU8(8, 8, 1, 0);
  try {
    mapper.observe(bad);
    ADD_FAILURE() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("does not fit its camera"), std::string::npos) << error.what();
  }
  mapper.reset();
  EXPECT_TRUE(mapper.observe(keyframeAt(102, 2.2)).empty());
}

// Step 6's surface map: the published depth of each fused keyframe in the
// TSDF, its mesh on the wall, moved by a loop closure, emptied by a reset;
// none without the confidence.
TEST(OnlineMapper, SurfaceMapMeshesThePublishedDepthAndFollowsReposingAndReset) {
  OnlineMapperOptions options = wallOptions();
  ASSERT_TRUE(options.surface.enabled);  // the default
  options.surface.voxel_size = 0.1;
  options.confidence.min_probability = 0;  // few views: below the shipped level everywhere
  OnlineMapper mapper(options, wallDepth);
  for (int i = 0; i < 5; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  ASSERT_NE(mapper.surface(), nullptr);
  EXPECT_EQ(mapper.surface()->keyframeCount(), 4u);  // keyframes 1-4 are fused
  const TriangleMesh mesh = mapper.surface()->mesh();
  ASSERT_GT(mesh.triangles.size(), 100u);
  for (const Eigen::Vector3f& p : mesh.vertices.points) ASSERT_NEAR(p.z(), test::kWallZ, 1e-3);
  for (const auto& colour : mesh.vertices.colors) ASSERT_EQ(colour[0], 128);  // the keyframes' grey
  // A loop closure moves keyframe 2 by 1 m along its optical axis: its depth
  // now lies at z = 6, beyond the band, so the wall loses its weight (the
  // mesh changes when it is next read) and it alone is too light for a mesh.
  const uint64_t revision = mapper.mapRevision();
  ASSERT_TRUE(mapper.updatePose(2, test::poseAt({1.0, 0, 1.0})));
  EXPECT_GT(mapper.mapRevision(), revision);
  EXPECT_FALSE(mapper.surface()->meshIsCurrent());
  EXPECT_TRUE(mapper.surface()->contains(2));
  const TriangleMesh moved = mapper.surface()->mesh();
  EXPECT_TRUE(mapper.surface()->meshIsCurrent());
  EXPECT_NE(moved.triangles.size(), mesh.triangles.size());
  for (const Eigen::Vector3f& p : moved.vertices.points)
    ASSERT_NEAR(p.z(), test::kWallZ, 1e-3);
  mapper.reset();
  ASSERT_NE(mapper.surface(), nullptr);
  EXPECT_EQ(mapper.surface()->keyframeCount(), 0u);
  EXPECT_TRUE(mapper.surface()->mesh().empty());

  options.confidence.enabled = false;  // nothing published: no surface map
  OnlineMapper without(options, wallDepth);
  for (int i = 0; i < 3; ++i) without.process(keyframeAt(i, 0.5 * i));
  EXPECT_EQ(without.surface(), nullptr);
}

}  // namespace
}  // namespace amhmvs
