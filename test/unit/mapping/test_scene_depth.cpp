// Scene depth for source selection from the data (scene_depth.h): depth maps
// of the keyframe itself and of other keyframes, and the bootstrap of the
// first pair by patches matched along epipolar lines
// (epipolar_depth_search.h), which also gives the first pair's depth range
// (depth_range.h rule 4); on a textured wall rendered exactly.
#include "amhmvs_mapping/mapping/scene_depth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/mapping/depth_range.h"
#include "amhmvs_mapping/mapping/source_selection.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

using test::poseAt;
constexpr int kWidth = 160, kHeight = 120;
constexpr double kFocal = 150;

// Smooth random texture on the wall: value noise on a lattice of `cell`
// metres (about 2.5 px at the wall's depth: no aliasing).
double wallTexture(double x, double y, double cell) {
  const auto lattice = [](long i, long j) {
    unsigned long h = static_cast<unsigned long>(i * 73856093L) ^ static_cast<unsigned long>(j * 19349663L);
    h = (h ^ (h >> 13)) * 0x5bd1e995UL;
    return static_cast<double>((h ^ (h >> 15)) % 256);
  };
  const double u = x / cell, v = y / cell;
  const long i = static_cast<long>(std::floor(u)), j = static_cast<long>(std::floor(v));
  const double a = u - i, b = v - j;
  return (1 - b) * ((1 - a) * lattice(i, j) + a * lattice(i + 1, j)) +
         b * ((1 - a) * lattice(i, j + 1) + a * lattice(i + 1, j + 1));
}

// Grey keyframe of the wall z = wall_z (world) seen from camera_to_world
// (cameras look along +z).
Keyframe wallKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world, double wall_z) {
  Keyframe keyframe;
  keyframe.id = id;
  keyframe.stamp = static_cast<double>(id);
  keyframe.camera = test::centredCamera(kWidth, kHeight, kFocal);
  keyframe.setCameraToWorld(camera_to_world);
  keyframe.image = ImageU8(kWidth, kHeight, 1);
  const double cell = 2.5 * wall_z / kFocal;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const Eigen::Vector3d direction = camera_to_world.linear() * keyframe.camera.backproject(x, y, 1.0);
      const Eigen::Vector3d origin = camera_to_world.translation();
      const Eigen::Vector3d hit = origin + (wall_z - origin.z()) / direction.z() * direction;
      keyframe.image.at(x, y) = static_cast<uint8_t>(std::lround(wallTexture(hit.x(), hit.y(), cell)));
    }
  }
  return keyframe;
}

// A store of two wall keyframes: 0 at the origin, 1 moved by `baseline` along x.
KeyframeStore wallPair(double wall_z, double baseline) {
  KeyframeStore store;
  store.add(wallKeyframe(0, poseAt({0, 0, 0}), wall_z));
  store.add(wallKeyframe(1, poseAt({baseline, 0, 0}), wall_z));
  return store;
}

DepthMap constantDepth(const PinholeCamera& camera, float depth) {
  DepthMap map;
  map.depth = ImageF(camera.width, camera.height, 1, depth);
  return map;
}

bool mentions(const SceneDepth& scene, const std::string& text) {
  return scene.source.find(text) != std::string::npos;
}

TEST(SceneDepth, MatchedAlongEpipolarLinesOnATexturedWall) {
  const double wall_z = 7.0;
  const Keyframe target = wallKeyframe(0, poseAt({0, 0, 0}), wall_z);
  const Keyframe source = wallKeyframe(1, poseAt({0.5, 0.1, 0.2}), wall_z);
  const std::vector<double> depths =
      matchDepthsAlongEpipolarLines(target.camera, target.image, source.camera, source.image);
  ASSERT_GE(depths.size(), 100u) << "most of the 256 textured patches match";
  EXPECT_NEAR(medianOf(depths), wall_z, 0.02 * wall_z);
  size_t wrong = 0;
  for (double d : depths) wrong += std::abs(d - wall_z) > 0.05 * wall_z;
  EXPECT_LE(wrong, depths.size() / 20) << "at most 5 % of the matches are off by more than 5 %";
}

TEST(SceneDepth, NothingMatchesWithoutTextureAndBadImagesThrow) {
  const Keyframe a = test::smallKeyframe(0, 0, poseAt({0, 0, 0}));
  const Keyframe b = test::smallKeyframe(1, 1, poseAt({0.3, 0, 0}));
  EXPECT_TRUE(matchDepthsAlongEpipolarLines(a.camera, a.image, b.camera, b.image).empty());
  EXPECT_THROW(matchDepthsAlongEpipolarLines(a.camera, ImageU8(5, 5, 1), b.camera, b.image), InputError);
  EpipolarSearchOptions bad;
  bad.patch_radius = 0;
  EXPECT_NE(bad.validate().find("patch_radius"), std::string::npos);
}

TEST(SceneDepth, FromOwnThenOtherDepthMapsThenMatchingThenDefault) {
  const double wall_z = 9.0;
  KeyframeStore store = wallPair(wall_z, 0.6);
  SceneDepthOptions options;

  // No depth anywhere yet: the bootstrap matches keyframe 1 against 0.
  SceneDepth scene = sceneDepth(store, 1, {0}, options);
  EXPECT_TRUE(mentions(scene, "epipolar")) << scene.source;
  EXPECT_NEAR(scene.depth, wall_z, 0.02 * wall_z);

  options.match_when_unknown = false;
  scene = sceneDepth(store, 1, {0}, options);
  EXPECT_EQ(scene.depth, options.default_scene_depth);
  EXPECT_TRUE(mentions(scene, "default")) << scene.source;

  // Keyframe 0's depth map (8 m, exact for this test) reprojected into 1.
  store.attachDepth(0, constantDepth(store.keyframe(0).camera, 8.0f));
  scene = sceneDepth(store, 1, {0}, options);
  EXPECT_NEAR(scene.depth, 8.0, 1e-6);
  EXPECT_TRUE(mentions(scene, "other keyframes' depth maps")) << scene.source;

  // Its own depth map wins over the others'.
  store.attachDepth(1, constantDepth(store.keyframe(1).camera, 4.0f));
  scene = sceneDepth(store, 1, {0}, options);
  EXPECT_NEAR(scene.depth, 4.0, 1e-6);
  EXPECT_TRUE(mentions(scene, "own depth map")) << scene.source;
}

TEST(SceneDepth, GivenRangeComesBeforeDepthMaps) {
  KeyframeStore store;
  Keyframe ranged = wallKeyframe(0, poseAt({0, 0, 0}), 9.0);
  ranged.depth_min = 2;
  ranged.depth_max = 4;
  store.add(ranged);
  store.attachDepth(0, constantDepth(ranged.camera, 8.0f));
  EXPECT_DOUBLE_EQ(sceneDepth(store, 0, {}, SceneDepthOptions()).depth, 3.0);
}

// The fountain case: the first pair 2 m apart facing a wall 12 m
// away. At the old fixed 3 m the rays would meet at ~37 deg (> 30: refused);
// the matched scene depth selects the pair.
TEST(SceneDepth, FirstPairFarAwayGetsSourcesWithoutTuning) {
  const double wall_z = 12.0;
  KeyframeStore store = wallPair(wall_z, 2.0);
  SourceSelectionOptions options;
  options.match_when_unknown = false;
  const SourceSelection fixed = selectSources(store, 1, options);
  EXPECT_TRUE(fixed.source_ids.empty());
  EXPECT_NE(fixed.reason.find("triangulation angle"), std::string::npos) << fixed.reason;

  options.match_when_unknown = true;
  const SourceSelection matched = selectSources(store, 1, options);
  EXPECT_EQ(matched.source_ids, std::vector<int64_t>{0}) << matched.reason;
  EXPECT_NEAR(matched.scene_depth.depth, wall_z, 0.03 * wall_z) << matched.scene_depth.source;
}

// The temple's case: an object 0.57 m away, far inside the default range
// [0.3, 30] m; the first pair's range comes from the matched patches.
TEST(SceneDepth, FirstPairDepthRangeFromMatchedPatches) {
  const double wall_z = 0.57;
  KeyframeStore store = wallPair(wall_z, 0.05);
  DepthRangeOptions options;
  const DepthRangeEstimate matched = estimateDepthRange(store, 1, {0}, options);
  EXPECT_EQ(matched.source, DepthRangeSource::kMatchedPatches) << matched.reason;
  EXPECT_LT(matched.min, wall_z);
  EXPECT_GT(matched.max, wall_z);
  EXPECT_GT(matched.min, 0.8 * 0.9 * wall_z) << "percentiles widened by 0.8 / 1.2 only";
  EXPECT_LT(matched.max, 1.2 * 1.1 * wall_z);

  options.match_when_unknown = false;
  EXPECT_EQ(estimateDepthRange(store, 1, {0}, options).source, DepthRangeSource::kDefault);
}

}  // namespace
}  // namespace amhmvs
