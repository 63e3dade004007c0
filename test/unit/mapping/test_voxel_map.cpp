// Global voxel map (voxel_map.h): averaging per voxel, exact incremental
// removal and re-posing, memory bounds, and no NaN/inf ever emitted.
#include "amhmvs_mapping/mapping/voxel_map.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

Eigen::Isometry3d pose(const Eigen::Vector3d& translation, double angle_rad = 0,
                       const Eigen::Vector3d& axis = Eigen::Vector3d::UnitY()) {
  Eigen::Isometry3d result = Eigen::Isometry3d::Identity();
  result.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).matrix();
  result.translation() = translation;
  return result;
}

KeyframePoint makePoint(float x, float y, float z, uint8_t grey = 100, float confidence = 1.f) {
  KeyframePoint point;
  point.position = Eigen::Vector3f(x, y, z);
  point.normal = Eigen::Vector3f(0, 0, -1);
  point.rgb[0] = point.rgb[1] = point.rgb[2] = grey;
  point.confidence = confidence;
  return point;
}

// A grid of n x n points at z-depth 2, spaced `spacing` apart.
KeyframePoints gridPoints(int n, float spacing, uint8_t grey = 100) {
  KeyframePoints points;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) points.push_back(makePoint(spacing * i, spacing * j, 2.f, grey));
  }
  return points;
}

void expectAllFinite(const PointCloud& cloud) {
  ASSERT_EQ(cloud.normals.size(), cloud.size());
  ASSERT_EQ(cloud.colors.size(), cloud.size());
  ASSERT_EQ(cloud.confidence.size(), cloud.size());
  ASSERT_EQ(cloud.counts.size(), cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_TRUE(cloud.points[i].allFinite()) << i;
    ASSERT_TRUE(cloud.normals[i].allFinite()) << i;
    ASSERT_TRUE(std::isfinite(cloud.confidence[i])) << i;
    ASSERT_GT(cloud.counts[i], 0u);
  }
}

// Index of the exported point nearest to `point`.
size_t nearest(const PointCloud& cloud, const Eigen::Vector3f& point) {
  size_t best = 0;
  for (size_t i = 1; i < cloud.size(); ++i) {
    if ((cloud.points[i] - point).squaredNorm() <
        (cloud.points[best] - point).squaredNorm()) {
      best = i;
    }
  }
  return best;
}

TEST(VoxelMap, AveragesPointsPerVoxel) {
  VoxelMapOptions options;
  options.leaf_size = 0.1;
  VoxelMap map(options);
  KeyframePoint a = makePoint(0.01f, 0.01f, 0.01f, 10, 1.f);
  a.normal = Eigen::Vector3f(0, 0, 1);
  a.rgb[2] = 30;
  KeyframePoint b = makePoint(0.03f, 0.05f, 0.07f, 20, 3.f);
  b.normal = Eigen::Vector3f(0, 1, 0);
  b.rgb[2] = 61;
  const KeyframePoint c = makePoint(0.55f, 0.f, 0.f);
  const VoxelMapUpdate update = map.addKeyframe(1, Eigen::Isometry3d::Identity(), KeyframePoints{a, b, c});
  EXPECT_EQ(update.added_points, 3u);
  EXPECT_EQ(map.voxelCount(), 2u);

  const PointCloud cloud = map.exportCloud();
  expectAllFinite(cloud);
  const size_t i = nearest(cloud, Eigen::Vector3f(0.02f, 0.03f, 0.04f));
  EXPECT_TRUE(cloud.points[i].isApprox(Eigen::Vector3f(0.02f, 0.03f, 0.04f), 1e-6f));
  EXPECT_TRUE(cloud.normals[i].isApprox(Eigen::Vector3f(0, 1, 1).normalized(), 1e-6f));
  EXPECT_EQ(cloud.colors[i], (std::array<uint8_t, 3>{15, 15, 46}));  // 45.5 rounds up
  EXPECT_FLOAT_EQ(cloud.confidence[i], 2.f);
  EXPECT_EQ(cloud.counts[i], 2u);
  EXPECT_EQ(cloud.counts[1 - i], 1u);
}

TEST(VoxelMap, OpposingNormalsGiveZeroNormalNotNaN) {
  VoxelMap map;
  KeyframePoint up = makePoint(0.001f, 0.001f, 0.001f);
  up.normal = Eigen::Vector3f(0, 0, 1);
  KeyframePoint down = up;
  down.normal = Eigen::Vector3f(0, 0, -1);
  map.addKeyframe(1, Eigen::Isometry3d::Identity(), KeyframePoints{up, down});
  const PointCloud cloud = map.exportCloud();
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3f::Zero());
}

TEST(VoxelMap, RePosedKeyframeMovesExactlyItsPoints) {
  VoxelMapOptions options;
  options.leaf_size = 0.05;
  VoxelMap map(options);
  // Points 0.3 m apart: one point per voxel.
  const KeyframePoints points_a = gridPoints(10, 0.3f, 50);
  const KeyframePoints points_b = gridPoints(10, 0.3f, 200);
  const Eigen::Isometry3d pose_a = pose(Eigen::Vector3d(0.1, 0.2, 0.3), 0.2);
  const Eigen::Isometry3d pose_b = pose(Eigen::Vector3d(60, 0, 0), -0.4);
  map.addKeyframe(1, pose_a, points_a);
  map.addKeyframe(2, pose_b, points_b);
  const PointCloud before = map.exportCloud();
  ASSERT_EQ(before.size(), 200u);

  const Eigen::Isometry3d new_pose_a =
      pose(Eigen::Vector3d(-5.3, 1.7, 2.2), 1.1, Eigen::Vector3d(1, 2, 3));
  const VoxelMapUpdate update = map.updatePose(1, new_pose_a);
  EXPECT_EQ(update.added_points, 100u);
  EXPECT_TRUE(update.evicted_keyframes.empty());
  EXPECT_EQ(map.keyframeIds(), (std::vector<int64_t>{1, 2}));  // keeps its place
  EXPECT_TRUE(map.pose(1).matrix().isApprox(new_pose_a.matrix()));
  const PointCloud after = map.exportCloud();
  expectAllFinite(after);
  ASSERT_EQ(after.size(), 200u);

  // Keyframe 2's points (x > 50) are bit-for-bit unchanged.
  std::vector<Eigen::Vector3f> b_before, b_after;
  for (const auto& p : before.points)
    if (p.x() > 50) b_before.push_back(p);
  for (const auto& p : after.points)
    if (p.x() > 50) b_after.push_back(p);
  EXPECT_EQ(b_before, b_after);
  ASSERT_EQ(b_after.size(), 100u);
  // Keyframe 1's points are the rigid transform of its camera-frame points.
  for (const KeyframePoint& point : points_a) {
    const Eigen::Vector3f expected = (new_pose_a * point.position.cast<double>()).cast<float>();
    const size_t i = nearest(after, expected);
    EXPECT_LT((after.points[i] - expected).norm(), 1e-5f);
    EXPECT_EQ(after.colors[i][0], 50);
    const Eigen::Vector3f normal = (new_pose_a.linear() * Eigen::Vector3d(0, 0, -1)).cast<float>();
    EXPECT_LT((after.normals[i] - normal).norm(), 1e-5f);
  }
}

TEST(VoxelMap, RemovalIsExactAfterManyRePoses) {
  VoxelMapOptions options;
  options.leaf_size = 0.1;
  VoxelMap map(options), reference(options);
  // Both keyframes fill the same voxels, far from the origin (large
  // coordinates make rounding errors visible if sums drift).
  const Eigen::Isometry3d far_away = pose(Eigen::Vector3d(1000.3, -2000.7, 500.1), 0.3);
  const KeyframePoints points_a = gridPoints(20, 0.037f, 10);
  const KeyframePoints points_b = gridPoints(20, 0.041f, 240);
  map.addKeyframe(1, far_away, points_a);
  map.addKeyframe(2, far_away, points_b);
  reference.addKeyframe(2, far_away, points_b);
  for (int i = 0; i < 500; ++i) {
    map.updatePose(1, pose(Eigen::Vector3d(1000 + 0.001 * i, -2000.7, 500.1), 0.3 + 0.01 * i));
    map.updatePose(1, far_away);
  }
  map.removeKeyframe(1);
  const PointCloud cloud = map.exportCloud();
  const PointCloud expected = reference.exportCloud();
  ASSERT_EQ(cloud.size(), expected.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_LT((cloud.points[i] - expected.points[i]).norm(), 1e-5f);
    EXPECT_LT((cloud.normals[i] - expected.normals[i]).norm(), 1e-6f);
    EXPECT_EQ(cloud.colors[i], expected.colors[i]);
    EXPECT_EQ(cloud.counts[i], expected.counts[i]);
    EXPECT_NEAR(cloud.confidence[i], expected.confidence[i], 1e-6f);
  }
  EXPECT_EQ(map.storedPointCount(), points_b.size());
  map.removeKeyframe(2);
  EXPECT_EQ(map.voxelCount(), 0u);
  EXPECT_EQ(map.storedPointCount(), 0u);
  EXPECT_EQ(map.exportCloud().size(), 0u);
}

TEST(VoxelMap, InvalidPointsAreSkippedAndCounted) {
  VoxelMap map;
  KeyframePoints points = gridPoints(3, 0.5f);  // 9 good points
  points.push_back(makePoint(kNaN, 0, 1));
  points.push_back(makePoint(0, kInf, 1));
  points.push_back(makePoint(0, 0, 1, 100, kNaN));
  points.push_back(makePoint(0, 0, 1, 100, -1.f));
  KeyframePoint bad_normal = makePoint(0, 0, 1);
  bad_normal.normal.x() = kNaN;
  points.push_back(bad_normal);
  points.push_back(makePoint(1e30f, 0, 1));  // beyond the voxel index range
  const VoxelMapUpdate update = map.addKeyframe(1, Eigen::Isometry3d::Identity(), points);
  EXPECT_EQ(update.added_points, 9u);
  EXPECT_EQ(update.skipped_invalid, 6u);
  EXPECT_EQ(map.totalSkippedInvalid(), 6u);
  EXPECT_EQ(map.storedPointCount(), 9u);
  const PointCloud cloud = map.exportCloud();
  EXPECT_EQ(cloud.size(), 9u);
  expectAllFinite(cloud);
  // A re-pose that throws the points out of range skips them too.
  const VoxelMapUpdate moved = map.updatePose(1, pose(Eigen::Vector3d(1e12, 0, 0)));
  EXPECT_EQ(moved.skipped_invalid, 9u);
  EXPECT_EQ(map.voxelCount(), 0u);
  expectAllFinite(map.exportCloud());
}

TEST(VoxelMap, BadInputIsAClearError) {
  VoxelMap map;
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_INPUT_ERROR(map.addKeyframe(3, nan_pose, gridPoints(2, 0.1f)), "keyframe 3", "non-finite");
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 2;
  EXPECT_INPUT_ERROR(map.addKeyframe(3, scaled, gridPoints(2, 0.1f)), "keyframe 3", "not rigid");
  EXPECT_EQ(map.keyframeCount(), 0u);
  EXPECT_INPUT_ERROR(map.removeKeyframe(4), "keyframe 4", "not in the map");
  EXPECT_INPUT_ERROR(map.updatePose(4, Eigen::Isometry3d::Identity()), "keyframe 4",
                     "not in the map");
  EXPECT_INPUT_ERROR(map.pose(4), "keyframe 4", "not in the map");
  map.addKeyframe(5, Eigen::Isometry3d::Identity(), gridPoints(2, 0.1f));
  EXPECT_INPUT_ERROR(map.updatePose(5, scaled), "keyframe 5", "not rigid");
  EXPECT_TRUE(map.pose(5).matrix().isIdentity());

  VoxelMapOptions options;
  options.leaf_size = 0;
  EXPECT_INPUT_ERROR(VoxelMap{options}, "leaf_size", "positive");
  options = VoxelMapOptions();
  options.max_voxels = 0;
  EXPECT_INPUT_ERROR(VoxelMap{options}, "max_voxels", "positive");
  options = VoxelMapOptions();
  options.min_points_per_voxel = 0;
  EXPECT_INPUT_ERROR(VoxelMap{options}, "min_points_per_voxel", "at least 1");
}

// min_points_per_voxel leaves out exactly the voxels that the same map
// without it exports with fewer points, exports the others unchanged, and
// stays so when a keyframe is removed or re-posed; each keyframe's points in
// exported voxels are what a brute-force count per voxel gives.
TEST(VoxelMap, ExportLeavesOutVoxelsWithFewerPoints) {
  VoxelMapOptions every;
  every.leaf_size = 0.1;
  VoxelMapOptions thick = every;
  thick.min_points_per_voxel = 3;
  VoxelMap all(every), filtered(thick);
  // Three keyframes over one surface, each with its own spacing, so that
  // voxels get 1 to 9+ points.
  const float spacings[] = {0.031f, 0.047f, 0.083f};
  std::map<int64_t, std::pair<Eigen::Isometry3d, KeyframePoints>> in_map;  // the brute force's copy
  for (int64_t id = 0; id < 3; ++id) {
    const KeyframePoints points = gridPoints(12 - 3 * id, spacings[id]);
    in_map[id] = {pose(Eigen::Vector3d(0.013 * id, 0, 0)), points};
    all.addKeyframe(id, in_map[id].first, points);
    filtered.addKeyframe(id, in_map[id].first, points);
  }
  const auto voxelOf = [&](const Eigen::Isometry3d& placed, const KeyframePoint& point) {
    const Eigen::Vector3d world = placed * point.position.cast<double>();
    return std::array<int64_t, 3>{static_cast<int64_t>(std::floor(world.x() / every.leaf_size)),
                                  static_cast<int64_t>(std::floor(world.y() / every.leaf_size)),
                                  static_cast<int64_t>(std::floor(world.z() / every.leaf_size))};
  };
  const auto expectFilteredExport = [&](const char* when) {
    std::map<std::array<int64_t, 3>, int> points_in_voxel;
    for (const auto& [id, keyframe] : in_map)
      for (const KeyframePoint& point : keyframe.second) ++points_in_voxel[voxelOf(keyframe.first, point)];
    for (const auto& [id, keyframe] : in_map) {
      size_t exported = 0;
      for (const KeyframePoint& point : keyframe.second) exported += points_in_voxel[voxelOf(keyframe.first, point)] >= 3;
      EXPECT_EQ(filtered.exportedPointCount(id), exported) << when << " keyframe " << id;
      EXPECT_EQ(all.exportedPointCount(id), keyframe.second.size()) << when << " keyframe " << id;
    }
    const PointCloud every_voxel = all.exportCloud(), kept = filtered.exportCloud();
    expectAllFinite(kept);
    size_t expected = 0, thin = 0;
    for (size_t i = 0; i < every_voxel.size(); ++i) {
      if (every_voxel.counts[i] < 3) {
        ++thin;
        continue;
      }
      ASSERT_LT(expected, kept.size()) << when;
      EXPECT_EQ(kept.points[expected], every_voxel.points[i]) << when << " voxel " << i;
      EXPECT_EQ(kept.counts[expected], every_voxel.counts[i]) << when;
      ++expected;
    }
    EXPECT_EQ(kept.size(), expected) << when;
    EXPECT_GT(thin, 0u) << when;  // the test leaves some out
    EXPECT_GT(expected, 0u) << when;
    EXPECT_EQ(filtered.voxelCount(), all.voxelCount()) << when;  // kept, only not exported
  };
  expectFilteredExport("three keyframes");
  all.removeKeyframe(1);
  filtered.removeKeyframe(1);
  in_map.erase(1);
  expectFilteredExport("one removed");
  in_map[2].first = pose(Eigen::Vector3d(0.05, 0.02, 0));
  all.updatePose(2, in_map[2].first);
  filtered.updatePose(2, in_map[2].first);
  expectFilteredExport("one re-posed");
  EXPECT_INPUT_ERROR(filtered.exportedPointCount(1), "keyframe 1", "not in the map");
}

TEST(VoxelMap, RegionOfInterestKeepsOutsidePointsOutOfTheMapButExactForRePosing) {
  VoxelMapOptions options;
  options.leaf_size = 0.05;  // one grid point per voxel
  options.region_min = Eigen::Vector3d(-1, -1, 0);
  options.region_max = Eigen::Vector3d(0.45, 1, 3);  // x of the 10 grid columns: 0 .. 0.9
  VoxelMap map(options);
  const KeyframePoints points = gridPoints(10, 0.1f);
  const VoxelMapUpdate update = map.addKeyframe(1, pose({0, 0, 0}), points);
  EXPECT_EQ(update.added_points, 50u);  // columns x = 0 .. 0.4
  EXPECT_EQ(update.outside_region, 50u);
  EXPECT_EQ(map.pointsOutsideRegion(), 50u);
  EXPECT_EQ(map.storedPointCount(), 100u);  // all kept for re-posing
  PointCloud cloud = map.exportCloud();
  ASSERT_EQ(cloud.size(), 50u);
  for (const Eigen::Vector3f& p : cloud.points) EXPECT_LE(p.x(), 0.45f);

  // Moved 0.5 m to -x: every point is inside now, exactly where it belongs.
  map.updatePose(1, pose({-0.5, 0, 0}));
  EXPECT_EQ(map.pointsOutsideRegion(), 0u);
  cloud = map.exportCloud();
  ASSERT_EQ(cloud.size(), 100u);
  for (const KeyframePoint& point : points) {
    const Eigen::Vector3f expected = point.position - Eigen::Vector3f(0.5f, 0, 0);
    EXPECT_LT((cloud.points[nearest(cloud, expected)] - expected).norm(), 1e-5f);
  }
  map.removeKeyframe(1);
  EXPECT_EQ(map.voxelCount(), 0u);
  EXPECT_EQ(map.pointsOutsideRegion(), 0u);

  options.region_max.x() = -1;  // empty box
  EXPECT_FALSE(options.validate().empty());
  options.region_max.x() = std::numeric_limits<double>::quiet_NaN();
  try {
    VoxelMap bad(options);
    FAIL() << "a NaN region was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("region_min must be below region_max"), std::string::npos) << e.what();
  }
}

TEST(VoxelMap, ReAddingAnIdReplacesItsContribution) {
  VoxelMap map;
  map.addKeyframe(1, Eigen::Isometry3d::Identity(), gridPoints(4, 0.5f));
  map.addKeyframe(2, pose(Eigen::Vector3d(10, 0, 0)), gridPoints(4, 0.5f));
  map.addKeyframe(1, Eigen::Isometry3d::Identity(), gridPoints(2, 0.5f));
  EXPECT_EQ(map.voxelCount(), 16u + 4u);
  EXPECT_EQ(map.storedPointCount(), 20u);
  EXPECT_EQ(map.keyframeIds(), (std::vector<int64_t>{2, 1}));  // re-added = newest
}

TEST(VoxelMap, BoundsEvictOldestKeyframesAndDropTheRest) {
  VoxelMapOptions options;
  options.leaf_size = 0.1;
  options.max_voxels = 1000;
  options.max_points = 2000;
  options.reposable_keyframes = 5;
  VoxelMap map(options);
  // Keyframes of 400 points in their own voxels: 2 fit in 1000 voxels.
  for (int64_t id = 0; id < 6; ++id) {
    const VoxelMapUpdate update =
        map.addKeyframe(id, pose(Eigen::Vector3d(100.0 * id, 0, 0)), gridPoints(20, 0.3f));
    if (id < 2) EXPECT_TRUE(update.evicted_keyframes.empty());
    if (id >= 2) EXPECT_EQ(update.evicted_keyframes, std::vector<int64_t>{id - 2});
    EXPECT_TRUE(update.frozen_keyframes.empty());
    EXPECT_LE(map.voxelCount(), options.max_voxels);
  }
  EXPECT_EQ(map.keyframeIds(), (std::vector<int64_t>{4, 5}));
  EXPECT_EQ(map.totalEvictedKeyframes(), 4u);

  // Points sharing voxels cost no voxel budget; reposable_keyframes binds:
  // the oldest are frozen, their voxels stay.
  for (int64_t id = 6; id < 12; ++id) {
    map.addKeyframe(id, pose(Eigen::Vector3d(500, 0, 0)), KeyframePoints(1, makePoint(0, 0, 2)));
    EXPECT_LE(map.keyframeCount(), options.reposable_keyframes);
  }
  EXPECT_EQ(map.keyframeIds(), (std::vector<int64_t>{7, 8, 9, 10, 11}));
  EXPECT_EQ(map.frozenKeyframeCount(), 3u);  // 4, 5, 6
  EXPECT_EQ(map.voxelCount(), 800u);  // the single points fall in a voxel of 5
  EXPECT_EQ(map.storedPointCount(), 5u);

  // A keyframe over the voxel budget: the oldest is frozen to make room for
  // it among the reposable ones, the others are removed (their voxel stays:
  // the frozen ones share it), and it keeps what fits beside the frozen voxels.
  const VoxelMapUpdate big =
      map.addKeyframe(20, pose(Eigen::Vector3d(-100, 0, 0)), gridPoints(40, 0.3f));  // 1600
  EXPECT_EQ(big.frozen_keyframes, std::vector<int64_t>{7});
  EXPECT_EQ(big.evicted_keyframes, (std::vector<int64_t>{8, 9, 10, 11}));
  EXPECT_EQ(map.keyframeIds(), std::vector<int64_t>{20});
  EXPECT_EQ(big.added_points, 200u);
  EXPECT_EQ(big.dropped_over_budget, 1400u);
  EXPECT_EQ(map.voxelCount(), 1000u);
  EXPECT_EQ(map.totalDroppedOverBudget(), 1400u);
  EXPECT_GT(map.memoryBytes(), 1000 * sizeof(KeyframePoint));
  expectAllFinite(map.exportCloud());

  // Alone over the budget in an empty map: the first 1000 voxels' points.
  VoxelMap fresh(options);
  const VoxelMapUpdate alone = fresh.addKeyframe(1, pose(Eigen::Vector3d(-100, 0, 0)), gridPoints(40, 0.3f));
  EXPECT_EQ(alone.added_points, 1000u);
  EXPECT_EQ(alone.dropped_over_budget, 600u);
}

// A place revisited for ever: the voxels stay the same, the points kept for
// re-posing stop growing once the oldest keyframes are frozen, and a frozen
// keyframe keeps its share of the voxels but can no longer move or be replaced.
TEST(VoxelMap, FrozenKeyframesStayInTheVoxelsAndKeepTheMemoryFlat) {
  VoxelMapOptions options;
  options.reposable_keyframes = 3;
  VoxelMap map(options);
  const Shared<KeyframePoints> points(gridPoints(4, 0.5f));  // 16 voxels
  size_t memory_at_10 = 0;
  for (int64_t id = 0; id < 200; ++id) {
    const VoxelMapUpdate update = map.addKeyframe(id, Eigen::Isometry3d::Identity(), points);
    EXPECT_EQ(update.frozen_keyframes, id >= 3 ? std::vector<int64_t>{id - 3} : std::vector<int64_t>{});
    EXPECT_EQ(map.voxelCount(), 16u);
    EXPECT_EQ(map.storedPointCount(), 16u * std::min<int64_t>(id + 1, 3));
    if (id == 9) memory_at_10 = map.memoryBytes();
  }
  // Only the frozen ids' set grows (tens of bytes a keyframe).
  EXPECT_LT(map.memoryBytes(), memory_at_10 + 190 * 64);
  EXPECT_EQ(map.keyframeIds(), (std::vector<int64_t>{197, 198, 199}));
  EXPECT_EQ(map.frozenKeyframeCount(), 197u);
  const PointCloud cloud = map.exportCloud();
  ASSERT_EQ(cloud.size(), 16u);
  for (uint32_t count : cloud.counts) EXPECT_EQ(count, 200u);  // every keyframe's points stay

  EXPECT_TRUE(map.isFrozen(5));
  EXPECT_FALSE(map.contains(5));
  EXPECT_INPUT_ERROR(map.updatePose(5, pose(Eigen::Vector3d(1, 0, 0))), "keyframe 5", "frozen");
  EXPECT_INPUT_ERROR(map.removeKeyframe(5), "keyframe 5", "frozen");
  const VoxelMapUpdate again = map.addKeyframe(5, pose(Eigen::Vector3d(3, 0, 0)), points);
  EXPECT_TRUE(again.refused_frozen);
  EXPECT_EQ(again.added_points, 0u);
  EXPECT_EQ(map.voxelCount(), 16u);
  EXPECT_EQ(map.totalRefusedFrozen(), 1u);

  // The reposable ones still move and leave exactly: what stays is the frozen 197.
  map.removeKeyframe(199);
  map.removeKeyframe(198);
  map.updatePose(197, pose(Eigen::Vector3d(10, 0, 0)));
  const PointCloud moved = map.exportCloud();
  ASSERT_EQ(moved.size(), 32u);
  for (uint32_t count : moved.counts) EXPECT_TRUE(count == 197u || count == 1u) << count;

  // max_points freezes too: 40 points keep two keyframes of 16.
  options.reposable_keyframes = 100;
  options.max_points = 40;
  VoxelMap few_points(options);
  for (int64_t id = 0; id < 5; ++id) few_points.addKeyframe(id, Eigen::Isometry3d::Identity(), points);
  EXPECT_EQ(few_points.keyframeIds(), (std::vector<int64_t>{3, 4}));
  EXPECT_EQ(few_points.frozenKeyframeCount(), 3u);
  EXPECT_EQ(few_points.storedPointCount(), 32u);
}

// The map keeps a keyframe's points for re-posing: the caller's buffer
// itself when every point is accepted (no copy per keyframe), a compacted
// copy when some are not; the map's contents do not depend on which.
TEST(VoxelMap, KeepsTheCallersPointsWithoutACopyUnlessSomeAreDropped) {
  VoxelMap map;
  const Shared<KeyframePoints> good(gridPoints(4, 0.5f));
  map.addKeyframe(1, pose(Eigen::Vector3d(1, 0, 0)), good);
  EXPECT_TRUE(map.keyframePoints(1).sameValue(good));
  map.updatePose(1, pose(Eigen::Vector3d(2, 0, 0)));
  EXPECT_TRUE(map.keyframePoints(1).sameValue(good));  // re-posing shares it too

  KeyframePoints with_bad = gridPoints(4, 0.5f);
  with_bad.insert(with_bad.begin() + 3, makePoint(kNaN, 0, 1));
  const Shared<KeyframePoints> mixed(with_bad);
  VoxelMap other;
  const VoxelMapUpdate update = other.addKeyframe(1, pose(Eigen::Vector3d(2, 0, 0)), mixed);
  EXPECT_EQ(update.skipped_invalid, 1u);
  ASSERT_FALSE(other.keyframePoints(1).sameValue(mixed));
  ASSERT_EQ(other.keyframePoints(1)->size(), good->size());
  for (size_t i = 0; i < good->size(); ++i)
    EXPECT_EQ((*other.keyframePoints(1))[i].position, (*good)[i].position) << i;  // in order, the bad one out
  const PointCloud a = map.exportCloud(), b = other.exportCloud();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a.points[i], b.points[i]) << i;
  EXPECT_INPUT_ERROR(map.keyframePoints(7), "keyframe 7", "not in the map");
}

}  // namespace
}  // namespace amhmvs
