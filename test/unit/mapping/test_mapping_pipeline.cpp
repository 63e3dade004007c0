// MappingPipeline (mapping_pipeline.h): queue, scheduling of new / late /
// refined depth maps, failures, pose updates, reset and typed statistics,
// with an injected estimator that returns the exact depth of a wall.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

using test::keyframeAt;
using test::wallDepth;

PipelineOptions wallPipeline(size_t queue_size = 100) {
  PipelineOptions options;
  options.mapper = test::wallOptions();
  options.queue_size = queue_size;
  options.report_period_s = 0;  // every line (the tests read them)
  return options;
}

// A pipeline on the wall estimator that records its log lines.
struct WallPipeline {
  explicit WallPipeline(const PipelineOptions& options, EstimateFunction primary = wallDepth,
                        EstimateFunction fallback = nullptr)
      : pipeline(options, std::move(primary), std::move(fallback), "injected",
                 [this](MappingPipeline::LogLevel, const std::string& line) { log.push_back(line); }) {}
  bool logged(const std::string& part) const {
    for (const std::string& line : log)
      if (line.find(part) != std::string::npos) return true;
    return false;
  }
  std::vector<std::string> log;
  MappingPipeline pipeline;
};

// "new 1", "late 0", "refined 0": what each output of the steps was.
std::vector<std::string> describe(const std::vector<PipelineOutput>& outputs) {
  std::vector<std::string> out;
  for (const PipelineOutput& output : outputs) {
    const KeyframeResult& r = output.result;
    out.push_back(std::string(r.late              ? "late "
                              : r.refined         ? "refined "
                              : r.fused_again     ? "again "
                              : r.deferred_fusion ? "deferred "
                                                  : "new ") +
                  std::to_string(r.id));
  }
  return out;
}

// Six keyframes queued at once along the wall, then step() until idle: the
// outputs in order (describe), each also handed to `each`.
std::vector<std::string> stepSixQueuedKeyframes(MappingPipeline* pipeline,
                                                const std::function<void(const PipelineOutput&)>& each = {}) {
  for (int i = 0; i < 6; ++i) pipeline->push(keyframeAt(i, 0.25 * i));
  std::vector<std::string> order;
  while (true) {
    const std::vector<PipelineOutput> outputs = pipeline->step();
    if (outputs.empty()) break;
    for (const std::string& what : describe(outputs)) order.push_back(what);
    if (each) for (const PipelineOutput& output : outputs) each(output);
  }
  return order;
}

TEST(MappingPipeline, FullQueueDropsTheOldestAndSaysWhatToChange) {
  PipelineOptions options = wallPipeline(2);
  options.skip_to_newest = false;  // drop-oldest alone (the next test: with the skip)
  WallPipeline wall(options);
  EXPECT_EQ(wall.pipeline.push(keyframeAt(0, 0.0)), 0u);
  EXPECT_EQ(wall.pipeline.push(keyframeAt(1, 0.5)), 0u);
  EXPECT_EQ(wall.pipeline.push(keyframeAt(2, 1.0)), 1u);  // keyframe 0 goes
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.keyframes_received, 3u);
  EXPECT_EQ(stats.dropped_queue_full, 1u);
  EXPECT_EQ(stats.queued, 2u);
  EXPECT_FALSE(stats.idle);
  EXPECT_TRUE(wall.logged("input queue full (2 keyframes): dropped the oldest, 1 dropped so far"));
  EXPECT_TRUE(wall.logged("lower max_image_size"));
  // The newest are processed, in order.
  EXPECT_EQ(describe(wall.pipeline.step()), std::vector<std::string>{"new 1"});
  EXPECT_EQ(describe(wall.pipeline.step()), (std::vector<std::string>{"new 2", "late 1"}));
}

TEST(MappingPipeline, AfterAnOverflowTheNewestKeyframeIsTakenAndTheSkippedOnesCounted) {
  WallPipeline wall(wallPipeline(3));
  // A burst that fits the queue is processed in order, every keyframe.
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  EXPECT_EQ(describe(wall.pipeline.step()), std::vector<std::string>{"new 0"});
  EXPECT_EQ(describe(wall.pipeline.step()), (std::vector<std::string>{"new 1", "late 0"}));
  EXPECT_EQ(wall.pipeline.stats().droppedTotal(), 0u);
  // Input faster than the estimator: 5 keyframes while 2 is queued
  // overflow the queue (2, 3, 4 dropped for newer ones), then the newest (7)
  // is taken and the queued 5 and 6 are skipped; nothing is silent.
  for (int i = 3; i < 8; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.dropped_queue_full, 3u);
  EXPECT_EQ(stats.queued, 3u);
  const std::vector<PipelineOutput> outputs = wall.pipeline.step();
  const std::vector<std::string> next = describe(outputs);
  ASSERT_FALSE(next.empty());
  EXPECT_EQ(next[0], "new 7");
  // The skipped 5 and 6 have no depth map of their own but stay as sources.
  const std::vector<int64_t>& sources = outputs[0].result.selection.source_ids;
  EXPECT_NE(std::find(sources.begin(), sources.end(), 6), sources.end());
  wall.pipeline.withMapper([](const OnlineMapper& mapper) {
    EXPECT_TRUE(mapper.store().contains(5) && mapper.store().contains(6));
    EXPECT_FALSE(mapper.store().contains(4));
  });
  stats = wall.pipeline.stats();
  EXPECT_EQ(stats.dropped_skipped_for_newer, 2u);
  EXPECT_EQ(stats.skipped_kept_as_sources, 2u);
  EXPECT_EQ(stats.queued, 0u);
  EXPECT_EQ(stats.droppedTotal(), 5u);
  EXPECT_EQ(stats.keyframes_received, 8u);
  EXPECT_TRUE(wall.logged("skipped 2 queued keyframes to the newest (keyframe 7; the last 2 stay as its source "
                          "views), 2 skipped so far"));
  EXPECT_TRUE(wall.logged("raise the keyframe distance"));
  // The input measured: how many keyframes can be mapped.
  EXPECT_TRUE(wall.logged("a keyframe arrives every ")) << wall.log.back();
  // Back to a rate the estimator keeps: in order again.
  wall.pipeline.push(keyframeAt(8, 4.0));
  wall.pipeline.push(keyframeAt(9, 4.5));
  EXPECT_EQ(describe(wall.pipeline.step())[0], "new 8");
  EXPECT_EQ(describe(wall.pipeline.step())[0], "new 9");
  EXPECT_EQ(wall.pipeline.stats().droppedTotal(), 5u);
}

TEST(MappingPipeline, SchedulesNewKeyframesFirstThenLateDepthMapsThenRefinements) {
  PipelineOptions options = wallPipeline();
  options.mapper.refinement.min_score_gain = 1.01;
  WallPipeline wall(options);
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  // Step 1: keyframe 0 has no source yet.
  std::vector<PipelineOutput> outputs = wall.pipeline.step();
  ASSERT_EQ(describe(outputs), std::vector<std::string>{"new 0"});
  EXPECT_FALSE(outputs[0].result.has_depth);
  EXPECT_GE(outputs[0].result.times.queue_wait_ms, 0.0);
  // Step 2: keyframe 1 (source 0), then the late depth map of 0 (source 1).
  outputs = wall.pipeline.step();
  ASSERT_EQ(describe(outputs), (std::vector<std::string>{"new 1", "late 0"}));
  EXPECT_EQ(outputs[1].result.selection.source_ids, std::vector<int64_t>{1});
  // Step 3: keyframe 2; nothing late; keyframe 1 could be refined (2 is a
  // better partner now) but only once the queue is empty: it is, so it is.
  outputs = wall.pipeline.step();
  ASSERT_GE(outputs.size(), 1u);
  EXPECT_EQ(describe(outputs)[0], "new 2");
  EXPECT_TRUE(outputs[0].result.fused_now);
  EXPECT_GT(outputs[0].result.times.estimate_ms, 0.0);
  EXPECT_GE(outputs[0].result.times.total_ms, outputs[0].result.times.estimate_ms);
  wall.pipeline.runUntilIdle(nullptr);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_TRUE(stats.idle);
  EXPECT_EQ(stats.depth_maps, 3u);  // the late one included
  EXPECT_EQ(stats.late_depth_maps, 1u);
  EXPECT_EQ(stats.keyframes_without_sources, 1u);
  EXPECT_EQ(stats.keyframes_fused, 3u);
  EXPECT_EQ(stats.keyframes_fused_again, stats.refined_depth_maps);
  EXPECT_EQ(stats.stored_keyframes, 3u);
  EXPECT_GT(stats.map_voxels, 0u);
  EXPECT_EQ(stats.droppedTotal(), 0u);
}

// With the overlap (kAlways: these tests have no GPU), a keyframe followed by
// another in the queue is fused during the next estimate: the same keyframes
// are fused into the same map, one step later.
TEST(MappingPipeline, FusionDuringTheNextEstimateFusesTheSameKeyframesOneStepLater) {
  PipelineOptions options = wallPipeline();
  options.fusion_overlap = FusionOverlap::kOff;
  WallPipeline at_once(options);
  options.fusion_overlap = FusionOverlap::kAlways;
  WallPipeline overlapped(options);
  std::vector<std::vector<int64_t>> fused_at_once, fused_overlapped;
  const auto record = [](std::vector<std::vector<int64_t>>* steps) {
    return [steps](const PipelineOutput& output) {
      std::vector<int64_t> ids;
      for (const FusedKeyframe& fused : output.result.fused) ids.push_back(fused.id);
      steps->push_back(ids);
    };
  };
  const std::vector<std::string> order_at_once = stepSixQueuedKeyframes(&at_once.pipeline, record(&fused_at_once));
  EXPECT_EQ(stepSixQueuedKeyframes(&overlapped.pipeline, record(&fused_overlapped)), order_at_once);
  // Outputs: new 0, new 1, late 0 (its late estimate ran keyframe 1's
  // deferred fusion first: nothing to fuse yet), new 2 .. new 5, then the
  // idle work. Keyframe 2's depth map completes 1, 0 and 2; overlapped they
  // come with keyframe 3, whose own fusion comes with 4, and so on; keyframe
  // 5 has no follower and is fused at once, after 4.
  ASSERT_EQ(order_at_once.size(), fused_at_once.size());
  ASSERT_EQ(fused_overlapped.size(), fused_at_once.size());
  ASSERT_GT(order_at_once.size(), 7u);
  EXPECT_EQ(order_at_once[3], "new 2");
  EXPECT_EQ(order_at_once[6], "new 5");
  EXPECT_EQ(fused_at_once[3], (std::vector<int64_t>{1, 0, 2}));
  EXPECT_TRUE(fused_overlapped[3].empty());
  EXPECT_EQ(fused_overlapped[4], fused_at_once[3]);
  EXPECT_EQ(fused_overlapped[5], fused_at_once[4]);
  EXPECT_EQ(fused_overlapped[6], (std::vector<int64_t>{4, 5}));
  for (size_t i = 7; i < order_at_once.size(); ++i) EXPECT_EQ(fused_overlapped[i], fused_at_once[i]) << i;
  const PipelineStats a = at_once.pipeline.stats(), b = overlapped.pipeline.stats();
  EXPECT_EQ(b.keyframes_fused, a.keyframes_fused);
  EXPECT_EQ(b.depth_maps, a.depth_maps);
  EXPECT_EQ(b.map_points_added, a.map_points_added);
  EXPECT_EQ(b.map_voxels, a.map_voxels);
  EXPECT_EQ(b.keyframes_waiting_for_fusion, 0u);
  EXPECT_TRUE(b.idle);
}

// The keyframe that would have carried a deferred fusion is dropped: with
// the queue empty, the fusion runs alone (nothing is lost).
TEST(MappingPipeline, DeferredFusionWhoseNextKeyframeIsDroppedRunsAlone) {
  PipelineOptions options = wallPipeline();
  options.fusion_overlap = FusionOverlap::kAlways;
  WallPipeline wall(options);
  for (int i = 0; i < 4; ++i) wall.pipeline.push(keyframeAt(i, 0.25 * i));
  Keyframe bad = keyframeAt(4, 1.0);
  bad.camera.fx = -1;
  wall.pipeline.push(std::move(bad));
  std::vector<PipelineOutput> deferred;
  wall.pipeline.runUntilIdle([&](const PipelineOutput& output) {
    if (output.result.deferred_fusion) deferred.push_back(output);
  });
  ASSERT_EQ(deferred.size(), 1u);
  EXPECT_EQ(deferred[0].result.id, 3);
  ASSERT_FALSE(deferred[0].result.fused.empty());
  EXPECT_EQ(deferred[0].result.fused.back().id, 3);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.dropped_invalid, 1u);
  EXPECT_EQ(stats.keyframes_fused, 4u);  // 0 (late), 1, 2, 3
  EXPECT_EQ(stats.keyframes_without_sources, 1u);  // only keyframe 0: the fusion alone is not one
  EXPECT_EQ(stats.keyframes_waiting_for_fusion, 0u);
}

TEST(MappingPipeline, RefinementWaitsWhileKeyframesAreQueued) {
  PipelineOptions options = wallPipeline();
  options.mapper.refinement.min_score_gain = 1.01;
  WallPipeline wall(options);
  const std::vector<std::string> order = stepSixQueuedKeyframes(&wall.pipeline);
  // Every new keyframe comes before the first refinement.
  size_t last_new = 0, first_refined = order.size();
  for (size_t i = 0; i < order.size(); ++i) {
    if (order[i].rfind("new", 0) == 0) last_new = i;
    if (order[i].rfind("refined", 0) == 0 && first_refined == order.size()) first_refined = i;
  }
  ASSERT_LT(first_refined, order.size()) << "no refinement happened";
  EXPECT_LT(last_new, first_refined);
}

// Fusing an early keyframe again with more views (it was fused with two and
// published nothing) is idle work too: after every queued keyframe, counted
// as a fusion again, with its own output.
TEST(MappingPipeline, FusionAgainWithMoreViewsWaitsWhileKeyframesAreQueued) {
  PipelineOptions options = wallPipeline();
  options.mapper.refinement.max_refinements = 0;
  WallPipeline wall(options);
  size_t published_again = 0;
  const std::vector<std::string> order = stepSixQueuedKeyframes(&wall.pipeline, [&](const PipelineOutput& output) {
    if (!output.result.fused_again) return;
    ASSERT_EQ(output.result.fused.size(), 1u);
    const ImageF& depth = output.result.fused[0].published.depth;
    published_again += std::count_if(depth.data.begin(), depth.data.end(), [](float d) { return std::isfinite(d); });
  });
  size_t last_new = 0, first_again = order.size(), again = 0;
  for (size_t i = 0; i < order.size(); ++i) {
    if (order[i].rfind("new", 0) == 0) last_new = i;
    if (order[i].rfind("again", 0) != 0) continue;
    ++again;
    if (first_again == order.size()) first_again = i;
  }
  ASSERT_GT(again, 0u) << "no fusion again happened";
  EXPECT_LT(last_new, first_again);
  EXPECT_GT(published_again, 0u);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.keyframes_fused_again, again);
  EXPECT_EQ(stats.depth_maps, 6u);  // a fusion again is no depth map
  EXPECT_EQ(stats.keyframes_without_sources, 1u);
  EXPECT_EQ(stats.fuse_again_failed, 0u);
  // Off: never.
  options.mapper.confidence.again_with_more_views = false;
  WallPipeline off(options);
  for (int i = 0; i < 6; ++i) off.pipeline.push(keyframeAt(i, 0.25 * i));
  off.pipeline.runUntilIdle(nullptr);
  EXPECT_EQ(off.pipeline.stats().keyframes_fused_again, 0u);
}

TEST(MappingPipeline, RejectedRefinementIsCountedLoggedAndNotPublished) {
  PipelineOptions options = wallPipeline();
  options.mapper.refinement.keep_only_better = true;
  WallPipeline wall(options, test::wallDepthWithABadRefinementOfKeyframe0);
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  std::vector<std::string> order;
  wall.pipeline.runUntilIdle([&](const PipelineOutput& output) { order.push_back(describe({output})[0]); });
  EXPECT_EQ(std::count(order.begin(), order.end(), "refined 0"), 0) << "a rejected refinement was published";
  EXPECT_EQ(std::count(order.begin(), order.end(), "refined 1"), 1);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.refinements_rejected, 1u);
  EXPECT_EQ(stats.refined_depth_maps, 1u);
  EXPECT_TRUE(wall.logged("refinement of keyframe 0 rejected, it keeps its depth map (confident pixels 768 -> 0"));
}

TEST(MappingPipeline, FailingGpuFallsBackToTheCpuAndIsCounted) {
  int primary_calls = 0;
  WallPipeline wall(wallPipeline(), [&](const DepthProblem&) -> DepthMap {
    ++primary_calls;
    throw BackendError("injected: out of memory");
  }, wallDepth);
  for (int i = 0; i < 5; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(primary_calls, 3);  // switch_to_cpu_after
  EXPECT_GE(stats.cpu_fallbacks, 3u);
  EXPECT_EQ(stats.backend, "injected failed, now cpu");
  EXPECT_EQ(stats.depth_maps, 5u);
  EXPECT_EQ(stats.dropped_backend_error, 0u);
  EXPECT_TRUE(wall.logged("out of memory"));
}

TEST(MappingPipeline, EstimateFailingEverywhereDropsTheKeyframeAndGoesOn) {
  int calls = 0;
  WallPipeline wall(wallPipeline(), [&](const DepthProblem& problem) {
    if (++calls == 1) throw BackendError("injected: device lost");
    return wallDepth(problem);
  });
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.dropped_backend_error, 1u);  // keyframe 1
  EXPECT_TRUE(wall.logged("dropped keyframe 1: injected: device lost"));
  EXPECT_GE(stats.depth_maps, 2u);
  wall.pipeline.withMapper([](const OnlineMapper& mapper) { EXPECT_FALSE(mapper.store().contains(1)); });
}

TEST(MappingPipeline, InvalidKeyframeIsDroppedWithTheReason) {
  WallPipeline wall(wallPipeline());
  Keyframe bad = keyframeAt(0, 0.0);
  bad.camera.fx = -1;
  wall.pipeline.push(std::move(bad));
  EXPECT_TRUE(wall.pipeline.step().empty());
  EXPECT_EQ(wall.pipeline.stats().dropped_invalid, 1u);
  EXPECT_TRUE(wall.logged("keyframe 0"));
  EXPECT_TRUE(wall.logged("focal"));
}

TEST(MappingPipeline, BoundedStoreEvictsTheOldestAndCountsIt) {
  PipelineOptions options = wallPipeline();
  options.mapper.store.max_keyframes = 3;
  WallPipeline wall(options);
  std::vector<int64_t> evicted;
  for (int i = 0; i < 6; ++i) wall.pipeline.push(keyframeAt(i, 0.25 * i));
  wall.pipeline.runUntilIdle([&](const PipelineOutput& output) {
    for (int64_t id : output.result.evicted) evicted.push_back(id);
  });
  EXPECT_EQ(evicted, (std::vector<int64_t>{0, 1, 2}));
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.stored_keyframes, 3u);
  EXPECT_EQ(stats.keyframes_evicted, 3u);
  EXPECT_EQ(stats.depth_maps, 6u);
  // Evicted keyframes keep their points in the map.
  wall.pipeline.withMapper([](const OnlineMapper& mapper) { EXPECT_TRUE(mapper.map().contains(1)); });
}

TEST(MappingPipeline, PoseUpdatesAreAppliedAtTheNextStepAndCounted) {
  WallPipeline wall(wallPipeline());
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  wall.pipeline.pushPoseUpdate(0, test::poseAt({0, 1, 0}));   // stored: moved up 1 m
  wall.pipeline.pushPoseUpdate(42, test::poseAt({0, 0, 0}));  // never seen
  Eigen::Isometry3d not_rigid = test::poseAt({0, 0, 0});
  not_rigid.linear() *= 2;
  wall.pipeline.pushPoseUpdate(1, not_rigid);
  wall.pipeline.step();
  const PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.pose_updates_applied, 1u);
  EXPECT_EQ(stats.pose_updates_not_stored, 1u);
  EXPECT_EQ(stats.bad_pose_updates, 1u);
  wall.pipeline.withMapper([](const OnlineMapper& mapper) {
    EXPECT_NEAR(mapper.store().keyframe(0).cameraToWorld().translation().y(), 1.0, 1e-12);
  });
}

TEST(MappingPipeline, ResetClearsCountersAtOnceAndTheMapAtTheNextStep) {
  WallPipeline wall(wallPipeline());
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  ASSERT_GT(wall.pipeline.stats().map_voxels, 0u);
  wall.pipeline.push(keyframeAt(3, 1.5));
  EXPECT_EQ(wall.pipeline.requestReset(), 1u);  // the queued keyframe
  PipelineStats stats = wall.pipeline.stats();
  EXPECT_EQ(stats.dropped_queue_full, 0u);  // discarded by the reset, not dropped for a newer keyframe
  EXPECT_EQ(stats.depth_maps, 0u);
  EXPECT_EQ(stats.keyframes_received, 0u);
  EXPECT_EQ(stats.queued, 0u);
  EXPECT_EQ(stats.backend, "injected");
  wall.pipeline.step();
  stats = wall.pipeline.stats();
  EXPECT_EQ(stats.map_voxels, 0u);
  EXPECT_EQ(stats.stored_keyframes, 0u);
  // Ids may start again after a reset.
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  EXPECT_EQ(wall.pipeline.stats().depth_maps, 3u);
}

TEST(MappingPipeline, OptionsChangeAtTheNextStepAndBadOnesAreRefused) {
  WallPipeline wall(wallPipeline());
  for (int i = 0; i < 3; ++i) wall.pipeline.push(keyframeAt(i, 0.5 * i));
  wall.pipeline.runUntilIdle(nullptr);
  const uint64_t fine_voxels = wall.pipeline.stats().map_voxels;
  OnlineMapperOptions coarse = wall.pipeline.options().mapper;
  coarse.map.leaf_size = 0.5;
  wall.pipeline.setOptions(coarse, PatchMatchOptions());
  wall.pipeline.step();
  EXPECT_LT(wall.pipeline.stats().map_voxels, fine_voxels);
  EXPECT_EQ(wall.pipeline.stats().reconfigurations, 1u);
  OnlineMapperOptions bad = coarse;
  bad.map.leaf_size = -1;
  wall.pipeline.setOptions(bad, PatchMatchOptions());
  wall.pipeline.step();
  EXPECT_EQ(wall.pipeline.stats().bad_reconfigurations, 1u);
  EXPECT_EQ(wall.pipeline.options().mapper.map.leaf_size, 0.5);
  EXPECT_TRUE(wall.logged("new options refused"));
}

TEST(MappingPipeline, InvalidOptionsAreRefusedWithEveryProblem) {
  PipelineOptions options = wallPipeline(0);
  options.switch_to_cpu_after = 0;
  try {
    MappingPipeline pipeline(options, wallDepth, nullptr, "injected");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("queue_size must be >= 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("switch_to_cpu_after"), std::string::npos) << e.what();
  }
}

TEST(MappingPipeline, StatFieldsHaveUniqueNamesAndReadTheirCounters) {
  std::set<std::string> names;
  PipelineStats stats;
  uint64_t value = 1;
  for (const PipelineStatField& field : pipelineStatFields()) {
    EXPECT_TRUE(names.insert(field.name).second) << field.name;
    stats.*field.value = value++;
  }
  EXPECT_EQ(stats.keyframes_received, 1u);
  EXPECT_EQ(stats.dropped_queue_full, 2u);
}

TEST(MappingPipeline, CpuBackendIsChosenWithAClearLineWhenThereIsNoGpu) {
  std::string gpu;
  if (cudaBackendAvailable(&gpu)) GTEST_SKIP() << "a GPU is present: " << gpu;
  std::vector<std::string> log;
  PipelineOptions options = wallPipeline();
  MappingPipeline pipeline(options, [&](MappingPipeline::LogLevel, const std::string& line) { log.push_back(line); });
  EXPECT_EQ(pipeline.backend(), Backend::kCpu);
  ASSERT_FALSE(log.empty());
  // A CUDA build without a driver or device, or a build without CUDA: said
  // plainly (no "CUDA driver version is insufficient").
  EXPECT_TRUE(log[0].rfind("no GPU found, using the CPU", 0) == 0 ||
              log[0].rfind("this build has no CUDA backend", 0) == 0)
      << log[0];
  EXPECT_NE(log[0].find("using the CPU"), std::string::npos) << log[0];
  EXPECT_EQ(log[0].find("driver version"), std::string::npos) << log[0];
}

}  // namespace
}  // namespace amhmvs

namespace amhmvs {
namespace {

// Frames between keyframes wait in one slot (the newest replaces an older
// one, counted), run only when no keyframe waits, and come out as frame-only
// results with the refined depths; a bad frame is counted and logged.
TEST(MappingPipeline, FramesBetweenKeyframesRefineDepthWhenNoKeyframeWaits) {
  PipelineOptions options = wallPipeline();
  options.mapper.depth_filter.enabled = true;
  options.mapper.depth_filter.publish_every = 1;
  WallPipeline wall(options);
  MappingPipeline& pipeline = wall.pipeline;
  for (int i = 0; i < 3; ++i) pipeline.push(keyframeAt(i, 0.5 * i));
  pipeline.runUntilIdle([](const PipelineOutput&) {});
  pipeline.observe(keyframeAt(100, 1.1));
  pipeline.observe(keyframeAt(101, 1.2));  // replaces 100
  pipeline.push(keyframeAt(3, 1.5));
  std::vector<PipelineOutput> outputs = pipeline.step();
  ASSERT_FALSE(outputs.empty());
  EXPECT_FALSE(outputs.front().result.frame_only) << "the keyframe first";
  EXPECT_EQ(outputs.front().result.id, 3);
  EXPECT_TRUE(std::any_of(outputs.begin(), outputs.end(), [](const PipelineOutput& o) { return o.result.frame_only; }))
      << "then the frame: no keyframe waits";
  size_t refined = 0;
  for (const PipelineOutput& output : outputs)
    if (output.result.frame_only) refined += output.result.refined_depths.size();
  EXPECT_EQ(refined, 3u);  // keyframes 1, 2 and 3 (the default 3 newest filters)
  const PipelineStats stats = pipeline.stats();
  EXPECT_EQ(stats.frames_observed, 1u);
  EXPECT_EQ(stats.frames_replaced, 1u);
  EXPECT_GE(stats.refined_depths, refined);

  Keyframe bad = keyframeAt(102, 1.6);
  bad.image = ImageU8(4, 4, 1, 0);
  pipeline.observe(bad);
  pipeline.runUntilIdle([](const PipelineOutput&) {});
  EXPECT_EQ(pipeline.stats().frames_refused, 1u);
  EXPECT_TRUE(wall.logged("frame")) << "the refusal is logged";
}

}  // namespace
}  // namespace amhmvs
