// The global map: a voxel-hashed point cloud built from per-keyframe dense
// points, updated incrementally when keyframes are added, removed or re-posed.
//
//   VoxelMap map(options);
//   map.addKeyframe(id, camera_to_world, points);  // points in the camera frame (shared, not copied)
//   map.updatePose(id, new_camera_to_world);       // loop closure
//   PointCloud cloud = map.exportCloud();          // one point per voxel, world
//
// Each voxel keeps double sums of its points (position relative to the voxel
// centre, normal, colour, confidence) and a count, so removing a keyframe
// subtracts exactly what it added; a voxel whose count drops to zero is erased
// (its sums restart from exact zeros). Each keyframe's accepted points and
// the voxel each went to are kept, so re-posing = remove with the old pose +
// add with the new one.
//
// Memory bound. Only the newest keyframes keep their points (at most
// VoxelMapOptions::reposable_keyframes of them and max_points points): before
// a keyframe is added, the oldest are frozen until it fits. A frozen
// keyframe's points stay in the voxels, but it can no longer be moved,
// removed or replaced (a map that revisits one place for hours stays the
// same size). Beyond max_voxels, the contributions of the oldest keyframes
// that still keep their points (never the one being added) are removed; what
// then still does not fit (the frozen voxels fill the budget, or the
// keyframe alone exceeds it) is dropped in point order and counted. Invalid points (NaN/inf
// position, normal or confidence, negative confidence, or beyond the voxel
// index range of +-2^20 leaves from the origin) are skipped and counted,
// never stored.
//
// Region of interest (VoxelMapOptions::region_min/max, world frame; default
// unbounded): points outside the box are counted and kept with their
// keyframe but enter no voxel, so that a re-pose that moves them inside
// (or out) is exact.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "amhmvs_mapping/core/shared.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/keyframe_point.h"

namespace amhmvs {

struct VoxelMapOptions {
  double leaf_size = 0.02;        // voxel edge, metres
  size_t max_voxels = 5000000;    // voxels in the map
  size_t max_points = 20000000;   // keyframe points kept for re-posing; beyond, the oldest keyframes are frozen
  // Keyframes that keep their points so that a loop closure can move them (or
  // a re-fusion replace them); beyond, the oldest are frozen.
  size_t reposable_keyframes = 600;
  // Voxels with fewer points are kept (and counted) but not exported: a
  // surface fused from noisy depth is a few voxels thick, and its outer
  // voxels hold few points that sit farther off it (realism room, 2 cm
  // voxels: 71 % of the one-point voxels within 2 cm, 99.6 % of those with
  // 9 or more). 1 = every voxel.
  int min_points_per_voxel = 1;
  // Region of interest, world frame: an axis-aligned box (min < max on each
  // axis; infinite bounds allowed). Default: everything.
  Eigen::Vector3d region_min = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d region_max = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// What one addKeyframe / updatePose did.
struct VoxelMapUpdate {
  size_t added_points = 0;         // points that entered a voxel
  size_t skipped_invalid = 0;      // NaN/inf values, negative confidence, out of index range
  size_t outside_region = 0;       // kept for re-posing, in no voxel
  size_t dropped_over_budget = 0;  // points that did not fit max_voxels / max_points
  std::vector<int64_t> evicted_keyframes;  // contributions removed to make room, oldest first
  std::vector<int64_t> frozen_keyframes;   // their points released (reposable_keyframes, max_points), oldest first
  bool refused_frozen = false;             // the id was frozen: nothing was added
};

class VoxelMap {
 public:
  // Throws InputError when the options are invalid.
  explicit VoxelMap(const VoxelMapOptions& options = VoxelMapOptions());

  // Adds keyframe `id`'s points (camera frame) at pose camera_to_world. An id
  // already in the map is replaced (its old contribution removed first); a
  // frozen id is refused (VoxelMapUpdate::refused_frozen, counted).
  // The map keeps the points for re-posing: shared with the caller when all
  // of them are accepted (the usual case), else a copy of the accepted ones.
  // Throws InputError for a non-finite or non-rigid pose.
  VoxelMapUpdate addKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world,
                             Shared<KeyframePoints> points);
  // Removes keyframe `id`'s contribution; throws InputError for an unknown id.
  void removeKeyframe(int64_t id);
  // Moves keyframe `id`'s points to a new pose. Throws InputError for an
  // unknown id or a bad pose. Evicts older keyframes when the moved points
  // need more voxels than are free.
  VoxelMapUpdate updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world);

  // True for the keyframes that keep their points (frozen ones: isFrozen).
  bool contains(int64_t id) const { return keyframes_.count(id) != 0; }
  bool isFrozen(int64_t id) const { return frozen_.count(id) != 0; }
  // Pose of a keyframe in the map; throws InputError for an unknown id.
  const Eigen::Isometry3d& pose(int64_t id) const;
  // The points kept for a keyframe (camera frame); throws InputError for an
  // unknown id.
  const Shared<KeyframePoints>& keyframePoints(int64_t id) const;
  std::vector<int64_t> keyframeIds() const;  // order of addition, oldest first

  // One point per voxel, world frame, voxels in ascending key order
  // (deterministic): the mean position, the normalised mean normal (zero when
  // the normals cancel out), the rounded mean colour, the mean confidence and
  // the number of points merged (PointCloud::counts). Voxels with fewer than
  // min_points_per_voxel points are left out.
  PointCloud exportCloud() const;
  // How many of keyframe `id`'s points are in voxels that exportCloud()
  // exports (all its points in the region when min_points_per_voxel is 1).
  // Throws InputError for an unknown id.
  size_t exportedPointCount(int64_t id) const;
  size_t voxelCount() const;
  size_t keyframeCount() const { return keyframes_.size(); }
  size_t storedPointCount() const { return stored_points_; }
  // Approximate heap bytes held (voxels, keyframe points, keys).
  size_t memoryBytes() const;

  // Totals since construction.
  size_t totalSkippedInvalid() const { return total_skipped_invalid_; }
  size_t totalDroppedOverBudget() const { return total_dropped_over_budget_; }
  // Points of the keyframes now in the map that lie outside the region.
  size_t pointsOutsideRegion() const { return points_outside_region_; }
  size_t totalEvictedKeyframes() const { return total_evicted_keyframes_; }
  size_t frozenKeyframeCount() const { return frozen_.size(); }
  size_t totalRefusedFrozen() const { return total_refused_frozen_; }

  const VoxelMapOptions& options() const { return options_; }
  // What exportCloud() leaves out (VoxelMapOptions::min_points_per_voxel);
  // the voxels stay as they are. Throws InputError below 1.
  void setMinPointsPerVoxel(int min_points);

 private:
  struct Voxel {
    double offset_sum[3] = {0, 0, 0};  // sum of (point - voxel centre)
    double normal_sum[3] = {0, 0, 0};
    double rgb_sum[3] = {0, 0, 0};
    double confidence_sum = 0;
    uint32_t count = 0;
  };
  struct KeyframeContribution {
    uint64_t sequence = 0;  // order of addition, key of order_
    Eigen::Isometry3d camera_to_world;
    Shared<KeyframePoints> points;  // accepted points, camera frame
    std::vector<uint64_t> keys;  // voxel of each accepted point
  };
  // Throws InputError for an unknown id.
  const KeyframeContribution& contributionOf(int64_t id) const;
  struct PlacedPoint {
    Eigen::Vector3d world;
    Eigen::Vector3d normal;
    uint64_t key;
  };
  // The voxels are split into shards by key hash, so that one keyframe's
  // update runs on all cores: each shard is summed and updated by one thread,
  // in point order (the result does not depend on the number of threads).
  static constexpr int kShards = 16;
  using VoxelTable = std::unordered_map<uint64_t, Voxel>;
  static int shardOf(uint64_t key) { return static_cast<int>((key * 0x9E3779B97F4A7C15ull) >> 60); }
  const VoxelTable& shard(uint64_t key) const { return shards_[shardOf(key)]; }

  // One voxel's share of a keyframe, so that the map's hash table is touched
  // once per voxel, not once per point.
  struct VoxelSums {
    uint64_t key = 0;
    Voxel sums;
    uint32_t first_point = 0;  // index of its first point (budget drops go in point order)
    bool dropped = false;      // over the voxel budget: not applied
  };
  // A keyframe's points summed per voxel: shard by shard (shard_begin), each
  // in order of first appearance; voxel_of_point[i] indexes `voxels` (-1:
  // outside the region).
  struct KeyframeSums {
    std::vector<VoxelSums> voxels;
    size_t shard_begin[kShards + 1] = {};
    std::vector<int32_t> voxel_of_point;
  };
  void sumPerVoxel(const std::vector<PlacedPoint>& placed, const KeyframePoints& points, KeyframeSums* sums);
  // Work buffers of one update, kept from update to update: on the GPU
  // machine, touching fresh memory (a page fault per 4 KiB, contended across
  // threads) took most of an update's time.
  // insert() evicts (removes) keyframes while its own placed points and sums
  // are in use: removal has its own.
  struct Scratch {
    std::vector<PlacedPoint> placed, removal_placed;
    KeyframeSums sums, removal_sums;
    std::vector<uint8_t> valid, shard_of_point;  // shard_of_point onwards: within sumPerVoxel only
    std::vector<VoxelSums> per_shard[kShards];
    std::vector<uint64_t> index_keys[kShards];
    std::vector<int32_t> index_entries[kShards];
  };
  // Adds (sign +1) or subtracts (-1) the sums that are not dropped.
  void apply(const KeyframeSums& sums, double sign);

  // World position/normal and voxel key of a point; false when non-finite or
  // out of index range.
  bool place(const Eigen::Isometry3d& camera_to_world, const KeyframePoint& point,
             PlacedPoint* placed) const;
  void removeContribution(const KeyframeContribution& contribution);
  // Adds a keyframe that is not in the map, evicting older ones as needed.
  VoxelMapUpdate insert(int64_t id, uint64_t sequence, const Eigen::Isometry3d& camera_to_world,
                        const Shared<KeyframePoints>& points);
  void evictOldest(VoxelMapUpdate* update);
  void freezeOldest(VoxelMapUpdate* update);
  Eigen::Vector3d voxelCentre(uint64_t key) const;

  VoxelMapOptions options_;
  VoxelTable shards_[kShards];
  Scratch scratch_;
  std::unordered_map<int64_t, KeyframeContribution> keyframes_;
  std::map<uint64_t, int64_t> order_;  // sequence -> id, oldest first
  uint64_t next_sequence_ = 0;
  size_t stored_points_ = 0;
  size_t total_skipped_invalid_ = 0;
  size_t total_dropped_over_budget_ = 0;
  size_t points_outside_region_ = 0;
  size_t total_evicted_keyframes_ = 0;
  size_t total_refused_frozen_ = 0;
  std::unordered_set<int64_t> frozen_;  // ids whose points stay in the voxels, released
};

// Empty when `camera_to_world` is a finite rigid transform; otherwise why not.
std::string validateRigidPose(const Eigen::Isometry3d& camera_to_world);

}  // namespace amhmvs
