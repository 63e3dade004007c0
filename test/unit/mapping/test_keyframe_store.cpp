// Keyframe store (keyframe_store.h): validation of added keyframes, pose
// updates, attachments with byte accounting and the bounded-memory eviction
// policy, including 10,000 keyframes passing through the store and the map.
#include "amhmvs_mapping/mapping/keyframe_store.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/voxel_map.h"
#include "mapping_test_helpers.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr int kWidth = test::kKeyframeWidth, kHeight = test::kKeyframeHeight;
using test::poseAt;

Keyframe makeKeyframe(int64_t id, double stamp, const Eigen::Isometry3d& camera_to_world,
                      int channels = 1) {
  return test::smallKeyframe(id, stamp, camera_to_world, channels, static_cast<uint8_t>(id % 251));
}

Keyframe makeKeyframe(int64_t id, double stamp = -1) {
  return makeKeyframe(id, stamp < 0 ? static_cast<double>(id) : stamp,
                      poseAt(Eigen::Vector3d(0.1 * id, 0, 0)));
}

DepthMap makeDepth(int width = kWidth, int height = kHeight) {
  DepthMap depth;
  depth.depth = ImageF(width, height, 1, 2.0f);
  depth.normal = ImageF(width, height, 3, 0.0f);
  depth.cost = ImageF(width, height, 1, 0.5f);
  return depth;
}

const size_t kImageBytes = kWidth * kHeight;
const size_t kDepthBytes = kWidth * kHeight * 5 * sizeof(float);

TEST(KeyframeStore, PoseHelpersRoundTrip) {
  const Eigen::Isometry3d pose = poseAt(Eigen::Vector3d(1, -2, 3), 30);
  PinholeCamera camera;
  setCameraToWorld(pose, &camera);
  EXPECT_TRUE(camera.center().isApprox(pose.translation(), 1e-12));
  EXPECT_TRUE(camera.viewingDirection().isApprox(pose.linear().col(2), 1e-12));
  EXPECT_TRUE(cameraToWorld(camera).matrix().isApprox(pose.matrix(), 1e-12));
  const Eigen::Vector3d point(0.3, 0.2, 4);
  EXPECT_TRUE(camera.toCamera(pose * point).isApprox(point, 1e-12));
}

TEST(KeyframeStore, AddsAndLooksUpKeyframes) {
  KeyframeStore store;
  EXPECT_TRUE(store.add(makeKeyframe(7)).empty());
  EXPECT_TRUE(store.add(makeKeyframe(3, 8.0)).empty());  // ids need not increase
  Keyframe rgb = makeKeyframe(11, 9.0, poseAt(Eigen::Vector3d::Zero()), 3);
  rgb.sparse_points = {Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(1, 0, 3)};
  store.add(rgb);

  EXPECT_EQ(store.size(), 3u);
  EXPECT_TRUE(store.contains(3));
  EXPECT_FALSE(store.contains(4));
  EXPECT_EQ(store.ids(), (std::vector<int64_t>{7, 3, 11}));
  EXPECT_EQ(store.pendingIds(), (std::vector<int64_t>{7, 3, 11}));
  EXPECT_EQ(store.keyframe(3).stamp, 8.0);
  EXPECT_EQ(store.state(11), KeyframeState::kPending);
  // The RGB keyframe: its image, its grey copy (converted once, for the
  // estimator) and its sparse points.
  EXPECT_EQ(store.entry(11).bytes, 4 * kImageBytes + 2 * sizeof(Eigen::Vector3d));
  EXPECT_EQ(store.bytes(), 6 * kImageBytes + 2 * sizeof(Eigen::Vector3d));
  EXPECT_EQ(store.entry(11).grayImage().channels, 1);
  EXPECT_EQ(store.entry(11).grayImage().data, toGray(rgb.image).data);
  EXPECT_EQ(&store.entry(3).grayImage(), &store.entry(3).keyframe.image);  // grey already: no copy
}

TEST(KeyframeStore, RejectsBadKeyframesWithClearMessages) {
  KeyframeStore store;
  store.add(makeKeyframe(1, 5.0));

  EXPECT_INPUT_ERROR(store.add(makeKeyframe(1, 6.0)), "keyframe 1", "duplicate id");

  Keyframe nan_pose = makeKeyframe(3, 6.0);
  nan_pose.camera.t.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_INPUT_ERROR(store.add(nan_pose), "keyframe 3", "non-finite");

  Keyframe scaled = makeKeyframe(4, 6.0);
  scaled.camera.R *= 1.5;
  EXPECT_INPUT_ERROR(store.add(scaled), "keyframe 4", "not rigid");

  Keyframe reflection = makeKeyframe(5, 6.0);
  reflection.camera.R = Eigen::Vector3d(1, 1, -1).asDiagonal();
  EXPECT_INPUT_ERROR(store.add(reflection), "keyframe 5", "not rigid");

  Keyframe zero_focal = makeKeyframe(6, 6.0);
  zero_focal.camera.fx = 0;
  EXPECT_INPUT_ERROR(store.add(zero_focal), "keyframe 6", "focal");

  Keyframe wrong_size = makeKeyframe(7, 6.0);
  wrong_size.image = ImageU8(16, 12);
  EXPECT_INPUT_ERROR(store.add(wrong_size), "keyframe 7", "16x12 but its camera is 32x24");

  Keyframe two_channels = makeKeyframe(8, 6.0);
  two_channels.image = ImageU8(kWidth, kHeight, 2);
  EXPECT_INPUT_ERROR(store.add(two_channels), "keyframe 8", "2 channels");

  Keyframe empty_image = makeKeyframe(9, 6.0);
  empty_image.image = ImageU8();
  EXPECT_INPUT_ERROR(store.add(empty_image), "keyframe 9", "empty");

  Keyframe nan_stamp = makeKeyframe(10, 6.0);
  nan_stamp.stamp = std::numeric_limits<double>::infinity();
  EXPECT_INPUT_ERROR(store.add(nan_stamp), "keyframe 10", "stamp");

  Keyframe inverted_range = makeKeyframe(11, 6.0);
  inverted_range.depth_min = 5;
  inverted_range.depth_max = 2;
  EXPECT_INPUT_ERROR(store.add(inverted_range), "keyframe 11", "depth range");

  Keyframe nan_point = makeKeyframe(12, 6.0);
  nan_point.sparse_points = {Eigen::Vector3d(1, 2, 3),
                             Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 1)};
  EXPECT_INPUT_ERROR(store.add(nan_point), "keyframe 12", "sparse point 1");

  // Nothing of the rejected keyframes was kept; equal stamps are fine.
  EXPECT_EQ(store.ids(), std::vector<int64_t>{1});
  EXPECT_EQ(store.bytes(), kImageBytes);
  store.add(makeKeyframe(2, 5.0));
  EXPECT_EQ(store.size(), 2u);
}

TEST(KeyframeStore, UnknownIdsAreClearErrors) {
  KeyframeStore store;
  store.add(makeKeyframe(1));
  EXPECT_INPUT_ERROR(store.keyframe(42), "keyframe 42", "unknown id");
  EXPECT_INPUT_ERROR(store.updatePose(42, Eigen::Isometry3d::Identity()), "keyframe 42",
                     "unknown id");
  EXPECT_INPUT_ERROR(store.attachDepth(42, makeDepth()), "keyframe 42", "unknown id");
  EXPECT_INPUT_ERROR(store.attachPoints(42, {}), "keyframe 42", "unknown id");
  EXPECT_INPUT_ERROR(store.remove(42), "keyframe 42", "unknown id");
  EXPECT_INPUT_ERROR(store.setSources(1, {42}), "keyframe 42", "not stored");
  EXPECT_INPUT_ERROR(store.setSources(1, {1}), "keyframe 1", "own source");
}

TEST(KeyframeStore, UpdatesPosesOfPendingAndDoneKeyframes) {
  KeyframeStore store;
  Keyframe keyframe = makeKeyframe(1, 0.0, poseAt(Eigen::Vector3d(1, 0, 0)));
  keyframe.sparse_points = {Eigen::Vector3d(1, 0, 2)};  // 2 m in front of the camera
  store.add(keyframe);
  store.add(makeKeyframe(2, 1.0));
  store.attachDepth(2, makeDepth());
  ASSERT_EQ(store.state(2), KeyframeState::kDone);

  const Eigen::Isometry3d moved = poseAt(Eigen::Vector3d(0, 0, 5), 90);
  store.updatePose(1, moved);  // pending
  store.updatePose(2, moved);  // done
  EXPECT_TRUE(store.keyframe(1).cameraToWorld().matrix().isApprox(moved.matrix(), 1e-12));
  EXPECT_TRUE(store.keyframe(2).cameraToWorld().matrix().isApprox(moved.matrix(), 1e-12));
  EXPECT_EQ(store.entry(1).pose_revision, 1u);
  EXPECT_EQ(store.state(2), KeyframeState::kDone);
  EXPECT_EQ(store.entry(2).depth->depth.width, kWidth);  // attachments survive
  // The sparse point moved with the keyframe: still 2 m in front.
  EXPECT_TRUE(store.keyframe(1)
                  .camera.toCamera(store.keyframe(1).sparse_points[0])
                  .isApprox(Eigen::Vector3d(0, 0, 2), 1e-12));

  Eigen::Isometry3d bad = moved;
  bad.translation().y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_INPUT_ERROR(store.updatePose(1, bad), "keyframe 1", "non-finite");
  bad = moved;
  bad.linear() *= 2;
  EXPECT_INPUT_ERROR(store.updatePose(1, bad), "keyframe 1", "not rigid");
  EXPECT_TRUE(store.keyframe(1).cameraToWorld().matrix().isApprox(moved.matrix(), 1e-12));
}

TEST(KeyframeStore, AttachmentsAreCheckedAndCounted) {
  KeyframeStore store;
  store.add(makeKeyframe(1));
  EXPECT_INPUT_ERROR(store.attachDepth(1, makeDepth(10, 10)), "keyframe 1",
                     "depth map is 10x10 but its camera is 32x24");
  DepthMap bad_normal = makeDepth();
  bad_normal.normal = ImageF(kWidth, kHeight, 1);
  EXPECT_INPUT_ERROR(store.attachDepth(1, bad_normal), "keyframe 1", "normal map");
  EXPECT_INPUT_ERROR(store.attachDepth(1, DepthMap()), "keyframe 1", "depth map");
  EXPECT_EQ(store.state(1), KeyframeState::kPending);

  store.attachDepth(1, makeDepth());
  EXPECT_EQ(store.state(1), KeyframeState::kDone);
  EXPECT_EQ(store.bytes(), kImageBytes + kDepthBytes);
  store.attachPoints(1, KeyframePoints(100));
  EXPECT_EQ(store.bytes(), kImageBytes + kDepthBytes + 100 * sizeof(KeyframePoint));
  store.attachPoints(1, KeyframePoints(10));  // replaced, not added
  EXPECT_EQ(store.entry(1).bytes, kImageBytes + kDepthBytes + 10 * sizeof(KeyframePoint));
  EXPECT_EQ(store.bytes(), store.entry(1).bytes);
  EXPECT_INPUT_ERROR(store.setSources(1, {}), "keyframe 1", "already done");
  store.remove(1);
  EXPECT_EQ(store.bytes(), 0u);
  EXPECT_EQ(store.size(), 0u);
}

TEST(KeyframeStore, EvictsByDocumentedPolicy) {
  KeyframeStoreOptions options;
  options.max_keyframes = 4;
  KeyframeStore store(options);
  for (int64_t id = 1; id <= 4; ++id) store.add(makeKeyframe(id));
  store.attachDepth(1, makeDepth());
  store.attachDepth(2, makeDepth());
  store.setSources(4, {1});  // 1 is needed by pending 4

  // Tier 1: done, not a source -> 2 (although 1 is older).
  EXPECT_EQ(store.add(makeKeyframe(5)), std::vector<int64_t>{2});
  // Tier 2: done but a source -> 1; 4 loses that source.
  EXPECT_EQ(store.add(makeKeyframe(6)), std::vector<int64_t>{1});
  EXPECT_TRUE(store.entry(4).sources.empty());
  // Tier 3: pending, oldest first.
  EXPECT_EQ(store.add(makeKeyframe(7)), std::vector<int64_t>{3});
  EXPECT_EQ(store.ids(), (std::vector<int64_t>{4, 5, 6, 7}));
  EXPECT_EQ(store.evictedCount(), 3u);
  EXPECT_INPUT_ERROR(store.keyframe(2), "keyframe 2", "unknown id");
}

// Brute force for nearestIds(): every stored keyframe sorted by distance,
// then age.
std::vector<int64_t> nearestByBruteForce(const KeyframeStore& store, const Eigen::Vector3d& point, size_t count,
                                         int64_t skip_id, bool with_depth_only) {
  std::vector<std::pair<double, int64_t>> all;  // ids() is oldest first: stable_sort keeps age
  for (int64_t id : store.ids()) {
    if (id == skip_id || (with_depth_only && store.state(id) != KeyframeState::kDone)) continue;
    all.emplace_back((store.keyframe(id).camera.center() - point).squaredNorm(), id);
  }
  std::stable_sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<int64_t> ids;
  for (size_t i = 0; i < all.size() && i < count; ++i) ids.push_back(all[i].second);
  return ids;
}

TEST(KeyframeStore, NearestIdsAgreeWithBruteForceThroughRemovalsEvictionsAndPoseUpdates) {
  KeyframeStoreOptions options;
  options.max_keyframes = 150;
  KeyframeStore store(options);
  uint32_t state = 12345;
  const auto uniform = [&state] {  // deterministic, in [-1, 1)
    state = state * 1664525u + 1013904223u;
    return static_cast<double>(state >> 8) / (1u << 23) - 1.0;
  };
  size_t evicted = 0;
  for (int64_t id = 0; id < 200; ++id) {
    // Every tenth keyframe at an earlier one's place: equal distances, decided by age.
    const Eigen::Vector3d centre = id % 10 == 9 ? store.keyframe(store.ids().back()).camera.center()
                                                : Eigen::Vector3d(uniform(), uniform(), 0.2 * uniform());
    evicted += store.add(makeKeyframe(id, static_cast<double>(id), poseAt(centre))).size();
    if (id % 3 == 0) store.attachDepth(id, makeDepth());
    if (id % 17 == 5) store.remove(id - 2);
    if (id % 13 == 0) {
      const int64_t moved = store.ids().front();
      store.updatePose(moved, poseAt(Eigen::Vector3d(uniform(), uniform(), 0)));
    }
  }
  ASSERT_GT(evicted, 0u);
  ASSERT_EQ(store.size(), 150u);
  const auto has_depth = [](const StoredKeyframe& stored) { return stored.state == KeyframeState::kDone; };
  for (int query = 0; query < 20; ++query) {
    const Eigen::Vector3d point(uniform(), uniform(), 0);
    const int64_t skip = store.ids()[query * 7];
    for (size_t count : {size_t{1}, size_t{8}, size_t{40}, size_t{500}}) {
      EXPECT_EQ(store.nearestIds(point, count, skip), nearestByBruteForce(store, point, count, skip, false));
      EXPECT_EQ(store.nearestIds(point, count, skip, has_depth), nearestByBruteForce(store, point, count, skip, true));
    }
  }
  EXPECT_EQ(store.nearestIds(Eigen::Vector3d::Zero(), 500, -1).size(), 150u);
}

// Stamps are labels: after a clock that jumped back (a bag played again) the
// earlier stamps are stored, and arrival order still decides the eviction.
TEST(KeyframeStore, EarlierStampsAfterAClockJumpAreStoredInArrivalOrder) {
  KeyframeStoreOptions options;
  options.max_keyframes = 2;
  KeyframeStore store(options);
  store.add(makeKeyframe(1, 1000.0));
  store.add(makeKeyframe(2, 1001.0));
  EXPECT_EQ(store.add(makeKeyframe(3, 5.0)), std::vector<int64_t>{1});  // the first to arrive goes
  EXPECT_EQ(store.add(makeKeyframe(4, 6.0)), std::vector<int64_t>{2});
  EXPECT_EQ(store.ids(), (std::vector<int64_t>{3, 4}));
  EXPECT_EQ(store.keyframe(3).stamp, 5.0);
}

TEST(KeyframeStore, RevisionChangesWithWhatSourceSelectionReads) {
  KeyframeStoreOptions options;
  options.max_keyframes = 2;
  KeyframeStore store(options);
  uint64_t last = store.revision();
  const auto changed = [&] {
    const bool moved = store.revision() != last;
    last = store.revision();
    return moved;
  };
  store.add(makeKeyframe(1));
  EXPECT_TRUE(changed());
  store.add(makeKeyframe(2));
  EXPECT_TRUE(changed());
  store.setSources(2, {1});
  EXPECT_FALSE(changed());
  store.attachDepth(1, makeDepth());
  EXPECT_TRUE(changed());
  store.attachPoints(1, KeyframePoints(10));
  EXPECT_FALSE(changed());
  store.updatePose(1, poseAt(Eigen::Vector3d(0.5, 0, 0)));
  EXPECT_TRUE(changed());
  EXPECT_INPUT_ERROR(store.add(makeKeyframe(1)), "keyframe 1", "duplicate");  // refused: nothing changed
  EXPECT_FALSE(changed());
  EXPECT_EQ(store.add(makeKeyframe(3)), std::vector<int64_t>{1});  // an eviction and an add
  EXPECT_TRUE(changed());
  store.remove(3);
  EXPECT_TRUE(changed());
}

TEST(KeyframeStore, RoomBeforePendingWorkIsEvictedCountsFreeBytesAndTierOneOnly) {
  KeyframeStoreOptions options;
  options.max_bytes = 10 * kImageBytes + 4 * kDepthBytes;
  KeyframeStore store(options);
  for (int64_t id = 1; id <= 5; ++id) store.add(makeKeyframe(id));
  store.attachDepth(1, makeDepth());
  store.attachDepth(2, makeDepth());
  store.attachDepth(3, makeDepth());
  store.setSources(5, {2});  // 2 is a source of pending 5: tier 2
  const size_t free_bytes = options.max_bytes - store.bytes();
  const size_t done_bytes = kImageBytes + kDepthBytes;
  // Tier 1: 1 and 3 (done, no source); not 2 (tier 2), 4 (pending) or 5 (the newest).
  EXPECT_EQ(store.bytesBeforePendingEvicted({}), free_bytes + 2 * done_bytes);
  // Keyframes about to be given attachments are spared.
  EXPECT_EQ(store.bytesBeforePendingEvicted({3}), free_bytes + done_bytes);
  // Points for 3 that take that room evict tier 1 only (1; 3 is spared as the one attached to).
  EXPECT_EQ(store.attachPoints(3, KeyframePoints((free_bytes + done_bytes) / sizeof(KeyframePoint))),
            std::vector<int64_t>{1});
  EXPECT_TRUE(store.contains(2) && store.contains(5));
}

TEST(KeyframeStore, ByteBudgetNeverExceededAndNewestKept) {
  KeyframeStoreOptions options;
  options.max_bytes = 3 * kImageBytes + kDepthBytes - 1;
  KeyframeStore store(options);
  store.add(makeKeyframe(1));
  store.add(makeKeyframe(2));
  store.add(makeKeyframe(3));
  // The depth map of 1 needs room: 2 goes (oldest pending other than 1 and
  // the newest, 3).
  EXPECT_EQ(store.attachDepth(1, makeDepth()), std::vector<int64_t>{2});
  EXPECT_LE(store.bytes(), options.max_bytes);
  EXPECT_EQ(store.add(makeKeyframe(4)), std::vector<int64_t>{1});
  EXPECT_EQ(store.ids(), (std::vector<int64_t>{3, 4}));

  // A keyframe larger than the whole budget is refused, nothing changes.
  Keyframe huge = makeKeyframe(5);
  huge.sparse_points.assign(options.max_bytes / sizeof(Eigen::Vector3d) + 1,
                            Eigen::Vector3d(0, 0, 1));
  EXPECT_INPUT_ERROR(store.add(huge), "keyframe 5", "budget");
  // An attachment that does not fit next to the newest keyframe is refused.
  EXPECT_INPUT_ERROR(store.attachPoints(3, KeyframePoints(options.max_bytes / 16)), "keyframe 3",
                     "budget");
  EXPECT_EQ(store.ids(), (std::vector<int64_t>{3, 4}));
  EXPECT_EQ(store.bytes(), 2 * kImageBytes);
}

TEST(KeyframeStore, TenThousandKeyframesThroughStoreAndMapStayInBudget) {
  KeyframeStoreOptions store_options;
  store_options.max_keyframes = 50;
  store_options.max_bytes = 40 * (kImageBytes + 300 * sizeof(KeyframePoint));
  KeyframeStore store(store_options);
  VoxelMapOptions map_options;
  map_options.leaf_size = 0.05;
  map_options.max_voxels = 20000;
  map_options.max_points = 60000;
  VoxelMap map(map_options);

  std::set<int64_t> evicted_from_store;
  size_t map_evictions = 0;
  for (int64_t id = 0; id < 10000; ++id) {
    // Sideways trajectory; every 7th keyframe re-visits an old place.
    const double x = (id % 7 == 0) ? 0.0 : 0.01 * id;
    const Eigen::Isometry3d pose = poseAt(Eigen::Vector3d(x, 0, 0));
    const auto record = [&](const std::vector<int64_t>& evicted) {
      for (int64_t gone : evicted) EXPECT_TRUE(evicted_from_store.insert(gone).second);
    };
    record(store.add(makeKeyframe(id, 0.1 * id, pose)));
    KeyframePoints points(300);
    for (int i = 0; i < 300; ++i) {
      points[i].position = Eigen::Vector3f(0.05f * (i % 20) - 0.5f, 0.05f * (i / 20) - 0.4f, 2.f);
      points[i].normal = Eigen::Vector3f(0, 0, -1);
    }
    if (id % 100 == 0) points[0].position.x() = std::numeric_limits<float>::quiet_NaN();
    if (id % 2 == 0) record(store.attachDepth(id, makeDepth()));
    record(store.attachPoints(id, points));
    const VoxelMapUpdate update = map.addKeyframe(id, pose, points);
    map_evictions += update.evicted_keyframes.size();
    if (id % 50 == 49 && map.contains(id - 50)) {
      map.updatePose(id - 50, poseAt(Eigen::Vector3d(x, 0.5, 0)));  // a loop closure
    }

    ASSERT_LE(store.size(), store_options.max_keyframes);
    ASSERT_LE(store.bytes(), store_options.max_bytes);
    ASSERT_LE(map.voxelCount(), map_options.max_voxels);
    ASSERT_LE(map.storedPointCount(), map_options.max_points);
    ASSERT_TRUE(store.contains(id));
    ASSERT_TRUE(map.contains(id));
  }
  for (int64_t gone : evicted_from_store) EXPECT_FALSE(store.contains(gone));
  EXPECT_EQ(evicted_from_store.size() + store.size(), 10000u);
  EXPECT_EQ(store.evictedCount(), evicted_from_store.size());
  EXPECT_GT(map_evictions, 0u);
  EXPECT_EQ(map.totalSkippedInvalid(), 100u);

  const PointCloud cloud = map.exportCloud();
  EXPECT_EQ(cloud.size(), map.voxelCount());
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_TRUE(cloud.points[i].allFinite());
    ASSERT_TRUE(cloud.normals[i].allFinite());
    ASSERT_TRUE(std::isfinite(cloud.confidence[i]));
  }
}

}  // namespace
}  // namespace amhmvs
