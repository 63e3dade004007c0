// The online mapping pipeline (online_mapper.h) with an injected estimator
// that returns the exact depth of a wall, so that sources, fusion, the map
// and loop-closure re-posing can be checked against exact numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

constexpr double kWallZ = 5.0;  // the wall z = 5 (world), facing the cameras

// Depth and normal of the wall z = kWallZ seen by cameras looking along +z.
DepthMap wallDepth(const DepthProblem& problem) {
  const PinholeCamera& camera = problem.reference_camera;
  const double depth = kWallZ - cameraToWorld(camera).translation().z();
  DepthMap map;
  map.depth = ImageF(camera.width, camera.height, 1, static_cast<float>(depth));
  map.normal = ImageF(camera.width, camera.height, 3, 0.0f);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) map.normal.at(x, y, 2) = -1.0f;
  map.cost = ImageF(camera.width, camera.height, 1, 0.1f);
  return map;
}

OnlineMapperOptions wallOptions() {
  OnlineMapperOptions options;
  options.sources.default_scene_depth = kWallZ;
  options.sources.min_overlap = 0.3;
  options.map.leaf_size = 0.05;
  return options;
}

Keyframe keyframeAt(int64_t id, double x) {
  return test::smallKeyframe(id, static_cast<double>(id), test::poseAt({x, 0, 0}), 3, 128);
}

TEST(OnlineMapper, FirstKeyframeIsASourceThenDepthFusionAndMap) {
  int calls = 0;
  OnlineMapper mapper(wallOptions(), [&](const DepthProblem& problem) {
    ++calls;
    return wallDepth(problem);
  });
  const KeyframeResult first = mapper.process(keyframeAt(0, 0.0));
  EXPECT_FALSE(first.has_depth);
  EXPECT_FALSE(first.selection.reason.empty());
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(mapper.store().state(0), KeyframeState::kDone);
  EXPECT_EQ(mapper.map().voxelCount(), 0u);

  const KeyframeResult second = mapper.process(keyframeAt(1, 0.5));
  ASSERT_TRUE(second.has_depth);
  EXPECT_EQ(second.selection.source_ids, std::vector<int64_t>{0});
  EXPECT_EQ(second.fusion_sources, 0);  // the first keyframe has no depth map
  EXPECT_TRUE(second.points.empty());

  const KeyframeResult third = mapper.process(keyframeAt(2, 1.0));
  ASSERT_TRUE(third.has_depth);
  EXPECT_EQ(third.fusion_sources, 1);  // keyframe 1
  ASSERT_FALSE(third.points.empty());
  EXPECT_EQ(calls, 2);
  for (const KeyframePoint& point : third.points) EXPECT_NEAR(point.position.z(), kWallZ, 1e-4);
  const MapCloud cloud = mapper.map().exportCloud();
  ASSERT_GT(cloud.size(), 0u);
  for (const Eigen::Vector3f& p : cloud.positions) EXPECT_NEAR(p.z(), kWallZ, 1e-4);
  EXPECT_EQ(mapper.mapRevision(), 1u);
}

TEST(OnlineMapper, LoopClosureMovesTheKeyframesMapPointsExactly) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 3; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  ASSERT_TRUE(mapper.map().contains(2));
  const MapCloud before = mapper.map().exportCloud();
  // Keyframe 2 moves 0.4 m up (y): its points move with it.
  EXPECT_TRUE(mapper.updatePose(2, test::poseAt({1.0, 0.4, 0})));
  const MapCloud after = mapper.map().exportCloud();
  ASSERT_EQ(after.size(), before.size());
  double mean_before = 0, mean_after = 0;
  for (size_t i = 0; i < before.size(); ++i) {
    mean_before += before.positions[i].y();
    mean_after += after.positions[i].y();
  }
  EXPECT_NEAR((mean_after - mean_before) / before.size(), 0.4, 0.03);  // within a voxel's rounding
  EXPECT_EQ(mapper.mapRevision(), 2u);
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

TEST(OnlineMapper, ResetAndVoxelSizeChange) {
  OnlineMapper mapper(wallOptions(), wallDepth);
  for (int i = 0; i < 3; ++i) mapper.process(keyframeAt(i, 0.5 * i));
  const size_t voxels = mapper.map().voxelCount();
  ASSERT_GT(voxels, 0u);
  OnlineMapperOptions coarser = wallOptions();
  coarser.map.leaf_size = 0.5;
  mapper.setOptions(coarser);
  EXPECT_LT(mapper.map().voxelCount(), voxels);
  EXPECT_GT(mapper.map().voxelCount(), 0u);
  coarser.sources.max_sources = 0;
  EXPECT_THROW(mapper.setOptions(coarser), InputError);
  mapper.reset();
  EXPECT_EQ(mapper.map().voxelCount(), 0u);
  EXPECT_EQ(mapper.store().size(), 0u);
}

}  // namespace
}  // namespace amhmvs
