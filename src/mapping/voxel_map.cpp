#include "amhmvs_mapping/mapping/voxel_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/fresh_memory.h"

namespace amhmvs {
namespace {

// Voxel indices are packed into 21 bits per axis: [-2^20, 2^20).
constexpr int64_t kIndexBits = 21;
constexpr int64_t kIndexOffset = int64_t{1} << (kIndexBits - 1);
constexpr int64_t kIndexMask = (int64_t{1} << kIndexBits) - 1;

// The key of a point outside the region of interest: in no voxel (a packed
// key uses 63 bits).
constexpr uint64_t kOutsideRegion = ~uint64_t{0};

bool indexInRange(double index) { return index >= -kIndexOffset && index < kIndexOffset; }

uint64_t packKey(int64_t ix, int64_t iy, int64_t iz) {
  return (static_cast<uint64_t>(ix + kIndexOffset) << (2 * kIndexBits)) |
         (static_cast<uint64_t>(iy + kIndexOffset) << kIndexBits) |
         static_cast<uint64_t>(iz + kIndexOffset);
}

Eigen::Vector3d unpackKey(uint64_t key) {
  const auto axis = [key](int shift) {
    return static_cast<double>(static_cast<int64_t>((key >> shift) & kIndexMask) - kIndexOffset);
  };
  return {axis(2 * kIndexBits), axis(kIndexBits), axis(0)};
}

uint8_t clampColor(double value) {
  return static_cast<uint8_t>(std::lround(std::min(255.0, std::max(0.0, value))));
}

}  // namespace

std::string VoxelMapOptions::validate() const {
  std::ostringstream why;
  if (!(std::isfinite(leaf_size) && leaf_size > 0)) {
    why << "leaf_size must be positive and finite (got " << leaf_size << ")\n";
  }
  if (max_voxels == 0) why << "max_voxels must be positive\n";
  if (max_points == 0) why << "max_points must be positive\n";
  if (reposable_keyframes == 0) why << "reposable_keyframes must be positive\n";
  if (!(min_points_per_voxel >= 1)) why << "min_points_per_voxel must be at least 1 (got " << min_points_per_voxel << ")\n";
  for (int axis = 0; axis < 3; ++axis) {
    if (!(region_min[axis] < region_max[axis]))  // also catches NaN
      why << "region_min must be below region_max on every axis (axis " << axis << ": " << region_min[axis]
          << " .. " << region_max[axis] << ")\n";
  }
  return why.str();
}

std::string validateRigidPose(const Eigen::Isometry3d& camera_to_world) {
  const Eigen::Matrix4d& m = camera_to_world.matrix();
  if (!m.allFinite()) return "pose contains non-finite values";
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double orthogonality = (r * r.transpose() - Eigen::Matrix3d::Identity()).norm();
  const double det = r.determinant();
  // Same tolerance as PinholeCamera::validate().
  if (orthogonality > 1e-3 || std::abs(det - 1.0) > 1e-3) {
    std::ostringstream why;
    why << "pose rotation is not rigid (|R R^T - I| = " << orthogonality << ", det R = " << det
        << ")";
    return why.str();
  }
  if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) return "pose's last row is not (0 0 0 1)";
  return "";
}

VoxelMap::VoxelMap(const VoxelMapOptions& options) : options_(options) {
  const std::string why = options.validate();
  if (!why.empty()) throw InputError("voxel map options: " + why);
}

Eigen::Vector3d VoxelMap::voxelCentre(uint64_t key) const {
  return (unpackKey(key).array() + 0.5).matrix() * options_.leaf_size;
}

bool VoxelMap::place(const Eigen::Isometry3d& camera_to_world, const KeyframePoint& point,
                     PlacedPoint* placed) const {
  if (!point.position.allFinite() || !point.normal.allFinite() ||
      !(std::isfinite(point.confidence) && point.confidence >= 0)) {
    return false;
  }
  placed->world = camera_to_world * point.position.cast<double>();
  placed->normal = camera_to_world.linear() * point.normal.cast<double>();
  const Eigen::Vector3d index = (placed->world / options_.leaf_size).array().floor();
  if (!placed->world.allFinite() || !indexInRange(index.x()) || !indexInRange(index.y()) ||
      !indexInRange(index.z())) {
    return false;
  }
  placed->key = packKey(static_cast<int64_t>(index.x()), static_cast<int64_t>(index.y()),
                        static_cast<int64_t>(index.z()));
  return true;
}

namespace {

// Insert-only open addressing (linear probing, a power-of-two table at most
// half full) from voxel key to an entry index: the per-keyframe grouping of
// sumPerVoxel, where std::unordered_map's node per key was most of the
// update's time.
class VoxelIndex {
 public:
  // The table lives in the caller's buffers (reused from update to update).
  VoxelIndex(size_t expected, std::vector<uint64_t>* keys, std::vector<int32_t>* entries)
      : keys_(*keys), entries_(*entries) {
    int bits = 4;
    while ((size_t{1} << bits) < 2 * expected) ++bits;
    keys_.assign(size_t{1} << bits, kOutsideRegion);  // never a key of a point in a voxel
    entries_.resize(keys_.size());
    mask_ = keys_.size() - 1;
    shift_ = 64 - bits;
  }
  // The entry of `key`; a new key gets `next_entry` and *inserted is set.
  int32_t find(uint64_t key, int32_t next_entry, bool* inserted) {
    // Fibonacci hashing: the product's top bits depend on every key bit.
    size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
    while (keys_[slot] != key) {
      if (keys_[slot] == kOutsideRegion) {
        keys_[slot] = key;
        entries_[slot] = next_entry;
        *inserted = true;
        return next_entry;
      }
      slot = (slot + 1) & mask_;
    }
    *inserted = false;
    return entries_[slot];
  }

 private:
  std::vector<uint64_t>& keys_;
  std::vector<int32_t>& entries_;
  size_t mask_ = 0;
  int shift_ = 60;
};

}  // namespace

void VoxelMap::sumPerVoxel(const std::vector<PlacedPoint>& placed, const KeyframePoints& points,
                           KeyframeSums* sums) {
  const size_t n = placed.size();
  const bool parallel = n > 20000;
  std::vector<uint8_t>& shard_of_point = scratch_.shard_of_point;
  shard_of_point.resize(n);
  sums->voxel_of_point.resize(n);
#pragma omp parallel for if (parallel)
  for (size_t i = 0; i < n; ++i) shard_of_point[i] = placed[i].key == kOutsideRegion ? kShards : shardOf(placed[i].key);
  std::vector<VoxelSums>* per_shard = scratch_.per_shard;
#pragma omp parallel for schedule(dynamic) if (parallel)
  for (int shard = 0; shard < kShards; ++shard) {
    // Each shard's thread picks its points out of all of them, in point
    // order (a byte each: cheaper than sorting the points by shard first).
    const uint8_t own = static_cast<uint8_t>(shard);
    const size_t count = static_cast<size_t>(std::count(shard_of_point.begin(), shard_of_point.end(), own));
    std::vector<VoxelSums>& out = per_shard[shard];
    out.clear();
    // At most half full: probing ends.
    VoxelIndex index(count, &scratch_.index_keys[shard], &scratch_.index_entries[shard]);
    uint64_t last_key = kOutsideRegion;
    int32_t entry = -1;
    for (size_t i = 0; i < n; ++i) {
      if (shard_of_point[i] != own) continue;
      const PlacedPoint& p = placed[i];
      // Neighbouring pixels (points come in image order) often share a voxel.
      if (p.key != last_key) {
        bool inserted = false;
        entry = index.find(p.key, static_cast<int32_t>(out.size()), &inserted);
        if (inserted) {
          out.emplace_back();
          out.back().key = p.key;
          out.back().first_point = static_cast<uint32_t>(i);
        }
        last_key = p.key;
      }
      sums->voxel_of_point[i] = entry;  // local to the shard until the offsets are known
      Voxel& voxel = out[entry].sums;
      const Eigen::Vector3d offset = p.world - voxelCentre(p.key);
      for (int k = 0; k < 3; ++k) {
        voxel.offset_sum[k] += offset[k];
        voxel.normal_sum[k] += p.normal[k];
        voxel.rgb_sum[k] += points[i].rgb[k];
      }
      voxel.confidence_sum += points[i].confidence;
      ++voxel.count;
    }
  }
  size_t begin = 0;
  for (int shard = 0; shard < kShards; ++shard) {
    sums->shard_begin[shard] = begin;
    begin += per_shard[shard].size();
  }
  sums->shard_begin[kShards] = begin;
  sums->voxels.resize(begin);
#pragma omp parallel for if (parallel)
  for (int shard = 0; shard < kShards; ++shard)
    std::copy(per_shard[shard].begin(), per_shard[shard].end(), sums->voxels.begin() + sums->shard_begin[shard]);
#pragma omp parallel for if (parallel)
  for (size_t i = 0; i < n; ++i) {
    const uint8_t shard = shard_of_point[i];
    sums->voxel_of_point[i] = shard < kShards ? sums->voxel_of_point[i] + static_cast<int32_t>(sums->shard_begin[shard]) : -1;
  }
}

void VoxelMap::apply(const KeyframeSums& sums, double sign) {
#pragma omp parallel for schedule(dynamic) if (sums.voxels.size() > 2000)
  for (int shard = 0; shard < kShards; ++shard) {
    VoxelTable& table = shards_[shard];
    for (size_t v = sums.shard_begin[shard]; v < sums.shard_begin[shard + 1]; ++v) {
      const VoxelSums& entry = sums.voxels[v];
      if (entry.dropped) continue;
      const auto found = table.try_emplace(entry.key).first;
      Voxel& voxel = found->second;
      for (int k = 0; k < 3; ++k) {
        voxel.offset_sum[k] += sign * entry.sums.offset_sum[k];
        voxel.normal_sum[k] += sign * entry.sums.normal_sum[k];
        voxel.rgb_sum[k] += sign * entry.sums.rgb_sum[k];
      }
      voxel.confidence_sum += sign * entry.sums.confidence_sum;
      if (sign > 0) {
        voxel.count += entry.sums.count;
      } else if ((voxel.count -= entry.sums.count) == 0) {
        table.erase(found);  // restart from exact zeros next time
      }
    }
  }
}

size_t VoxelMap::voxelCount() const {
  size_t count = 0;
  for (const VoxelTable& table : shards_) count += table.size();
  return count;
}

void VoxelMap::removeContribution(const KeyframeContribution& contribution) {
  const KeyframePoints& points = contribution.points;
  const size_t n = points.size();
  std::vector<PlacedPoint>& placed = scratch_.removal_placed;
  placed.resize(n);
#pragma omp parallel for if (n > 20000)
  for (size_t i = 0; i < n; ++i) {
    // Recomputed exactly as when added; the stored key guards against any
    // difference in rounding (the sums are subtracted from the same voxel).
    place(contribution.camera_to_world, points[i], &placed[i]);
    placed[i].key = contribution.keys[i];
  }
  for (uint64_t key : contribution.keys) points_outside_region_ -= key == kOutsideRegion;
  KeyframeSums& sums = scratch_.removal_sums;
  sumPerVoxel(placed, points, &sums);
  apply(sums, -1.0);
}

void VoxelMap::freezeOldest(VoxelMapUpdate* update) {
  const auto oldest = order_.begin();
  const int64_t id = oldest->second;
  const auto it = keyframes_.find(id);
  // Its sums stay in the voxels; the points that could take them out again go.
  for (uint64_t key : it->second.keys) points_outside_region_ -= key == kOutsideRegion;
  stored_points_ -= it->second.points->size();
  keyframes_.erase(it);
  order_.erase(oldest);
  frozen_.insert(id);
  update->frozen_keyframes.push_back(id);
}

void VoxelMap::evictOldest(VoxelMapUpdate* update) {
  const auto oldest = order_.begin();
  const int64_t id = oldest->second;
  const auto it = keyframes_.find(id);
  removeContribution(it->second);
  stored_points_ -= it->second.points->size();
  keyframes_.erase(it);
  order_.erase(oldest);
  update->evicted_keyframes.push_back(id);
  ++total_evicted_keyframes_;
}

VoxelMapUpdate VoxelMap::insert(int64_t id, uint64_t sequence,
                                const Eigen::Isometry3d& camera_to_world,
                                const Shared<KeyframePoints>& points) {
  VoxelMapUpdate update;
  const KeyframePoints& input = points;
  const size_t n = input.size();
  std::vector<PlacedPoint>& placed = scratch_.placed;
  std::vector<uint8_t>& valid = scratch_.valid;
  placed.resize(n);
  valid.resize(n);
  const auto inside = [this](const Eigen::Vector3d& world) {
    return (world.array() >= options_.region_min.array()).all() && (world.array() <= options_.region_max.array()).all();
  };
#pragma omp parallel for if (n > 20000)
  for (size_t i = 0; i < n; ++i) {
    valid[i] = place(camera_to_world, input[i], &placed[i]);
    if (valid[i] && !inside(placed[i].world)) placed[i].key = kOutsideRegion;
  }
  update.skipped_invalid = n - static_cast<size_t>(std::count(valid.begin(), valid.end(), uint8_t{1}));

  // The usable points in order: all of them (shared, no copy: the usual
  // case), or those that are valid and within max_points (compacted).
  Shared<KeyframePoints> accepted_shared = points;
  if (update.skipped_invalid > 0 || n > options_.max_points) {
    KeyframePoints compacted;
    compacted.reserve(std::min(n, options_.max_points));
    size_t count = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!valid[i]) continue;
      if (count >= options_.max_points) {
        ++update.dropped_over_budget;
        continue;
      }
      placed[count++] = placed[i];
      compacted.push_back(input[i]);
    }
    placed.resize(count);
    accepted_shared = Shared<KeyframePoints>(std::move(compacted));
  }
  const KeyframePoints& accepted = accepted_shared;
  KeyframeSums& sums = scratch_.sums;
  sumPerVoxel(placed, accepted, &sums);
  std::vector<VoxelSums>& voxels = sums.voxels;

  // Make room: the oldest keyframes' points are released until the new ones
  // fit, then the oldest contributions removed until the new voxels do.
  const auto newVoxelsNeeded = [&]() {
    size_t fresh = 0;
    for (const VoxelSums& entry : voxels) fresh += shard(entry.key).count(entry.key) == 0;
    return fresh;
  };
  while (!order_.empty() && (stored_points_ + placed.size() > options_.max_points ||
                             keyframes_.size() + 1 > options_.reposable_keyframes)) {
    freezeOldest(&update);
  }
  while (!order_.empty() && voxelCount() + voxels.size() > options_.max_voxels &&
         voxelCount() + newVoxelsNeeded() > options_.max_voxels) {
    evictOldest(&update);
  }
  // Alone over the voxel budget: the voxels beyond it (in order of first
  // appearance) are dropped with their points.
  if (voxelCount() + voxels.size() > options_.max_voxels) {
    std::vector<VoxelSums*> by_first_point;
    for (VoxelSums& entry : voxels) by_first_point.push_back(&entry);
    std::sort(by_first_point.begin(), by_first_point.end(),
              [](const VoxelSums* a, const VoxelSums* b) { return a->first_point < b->first_point; });
    size_t voxels_after = voxelCount();
    for (VoxelSums* entry : by_first_point) {
      if (shard(entry->key).count(entry->key)) continue;
      if (voxels_after >= options_.max_voxels) {
        entry->dropped = true;
      } else {
        ++voxels_after;
      }
    }
  }
  apply(sums, 1.0);

  KeyframeContribution kept;
  kept.sequence = sequence;
  kept.camera_to_world = camera_to_world;
  const bool any_dropped = std::any_of(voxels.begin(), voxels.end(), [](const VoxelSums& v) { return v.dropped; });
  if (!any_dropped) {  // the usual case: every accepted point is kept
    const size_t count = placed.size();
    reserveTouched(&kept.keys, count);  // kept: fresh memory every time
    kept.keys.resize(count);
    size_t outside = 0;
#pragma omp parallel for reduction(+ : outside) if (count > 20000)
    for (size_t i = 0; i < count; ++i) {
      kept.keys[i] = placed[i].key;
      outside += sums.voxel_of_point[i] < 0;
    }
    update.outside_region = outside;
    update.added_points = count - outside;
    kept.points = accepted_shared;
  } else {
    KeyframePoints survivors;
    for (size_t i = 0; i < placed.size(); ++i) {
      const int32_t slot = sums.voxel_of_point[i];
      if (slot >= 0 && voxels[slot].dropped) {
        ++update.dropped_over_budget;
        continue;
      }
      if (slot >= 0) {
        ++update.added_points;
      } else {
        ++update.outside_region;
      }
      survivors.push_back(accepted[i]);
      kept.keys.push_back(placed[i].key);
    }
    kept.points = Shared<KeyframePoints>(std::move(survivors));
  }
  points_outside_region_ += update.outside_region;
  stored_points_ += kept.points->size();
  keyframes_[id] = std::move(kept);
  order_[sequence] = id;
  total_skipped_invalid_ += update.skipped_invalid;
  total_dropped_over_budget_ += update.dropped_over_budget;
  return update;
}

VoxelMapUpdate VoxelMap::addKeyframe(int64_t id, const Eigen::Isometry3d& camera_to_world,
                                     Shared<KeyframePoints> points) {
  const std::string why = validateRigidPose(camera_to_world);
  if (!why.empty()) throw InputError("voxel map: keyframe " + std::to_string(id) + ": " + why);
  if (isFrozen(id)) {
    ++total_refused_frozen_;
    VoxelMapUpdate refused;
    refused.refused_frozen = true;
    return refused;
  }
  if (contains(id)) removeKeyframe(id);
  return insert(id, next_sequence_++, camera_to_world, points);
}

void VoxelMap::removeKeyframe(int64_t id) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) {
    throw InputError("voxel map: keyframe " + std::to_string(id) +
                     (isFrozen(id) ? " is frozen (older than the newest reposable_keyframes): it stays"
                                   : " is not in the map"));
  }
  removeContribution(it->second);
  stored_points_ -= it->second.points->size();
  order_.erase(it->second.sequence);
  keyframes_.erase(it);
}

VoxelMapUpdate VoxelMap::updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) {
    throw InputError("voxel map: cannot update the pose of keyframe " + std::to_string(id) +
                     (isFrozen(id) ? ": it is frozen (older than the newest reposable_keyframes)"
                                   : ": it is not in the map"));
  }
  const std::string why = validateRigidPose(camera_to_world);
  if (!why.empty()) throw InputError("voxel map: keyframe " + std::to_string(id) + ": " + why);
  // Keep the keyframe's place in the eviction order.
  const uint64_t sequence = it->second.sequence;
  const Shared<KeyframePoints> points = it->second.points;  // shared: no copy
  removeKeyframe(id);
  return insert(id, sequence, camera_to_world, points);
}

const VoxelMap::KeyframeContribution& VoxelMap::contributionOf(int64_t id) const {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) {
    throw InputError("voxel map: keyframe " + std::to_string(id) + " is not in the map");
  }
  return it->second;
}

const Eigen::Isometry3d& VoxelMap::pose(int64_t id) const { return contributionOf(id).camera_to_world; }

const Shared<KeyframePoints>& VoxelMap::keyframePoints(int64_t id) const { return contributionOf(id).points; }

std::vector<int64_t> VoxelMap::keyframeIds() const {
  std::vector<int64_t> ids;
  ids.reserve(order_.size());
  for (const auto& entry : order_) ids.push_back(entry.second);
  return ids;
}

size_t VoxelMap::memoryBytes() const {
  // Hash nodes carry the key, the value and about two pointers of overhead.
  size_t voxel_bytes = 0;
  for (const VoxelTable& table : shards_) {
    voxel_bytes += table.size() * (sizeof(Voxel) + sizeof(uint64_t) + 16) + table.bucket_count() * sizeof(void*);
  }
  const size_t point_bytes = stored_points_ * (sizeof(KeyframePoint) + sizeof(uint64_t));
  const size_t keyframe_bytes = keyframes_.size() * (sizeof(KeyframeContribution) + 64) + frozen_.size() * 32;
  return voxel_bytes + point_bytes + keyframe_bytes;
}

void VoxelMap::setMinPointsPerVoxel(int min_points) {
  VoxelMapOptions changed = options_;
  changed.min_points_per_voxel = min_points;
  const std::string why = changed.validate();
  if (!why.empty()) throw InputError("voxel map: " + why);
  options_ = changed;
}

size_t VoxelMap::exportedPointCount(int64_t id) const {
  size_t exported = 0;
  for (uint64_t key : contributionOf(id).keys) {
    if (key == kOutsideRegion) continue;
    exported += static_cast<int64_t>(shard(key).at(key).count) >= options_.min_points_per_voxel;
  }
  return exported;
}

PointCloud VoxelMap::exportCloud() const {
  std::vector<uint64_t> keys;
  keys.reserve(voxelCount());
  for (const VoxelTable& table : shards_) {
    for (const auto& entry : table) keys.push_back(entry.first);
  }
  std::sort(keys.begin(), keys.end());

  PointCloud cloud;
  cloud.points.reserve(keys.size());
  cloud.normals.reserve(keys.size());
  cloud.colors.reserve(keys.size());
  cloud.confidence.reserve(keys.size());
  cloud.counts.reserve(keys.size());
  for (uint64_t key : keys) {
    const Voxel& voxel = shard(key).at(key);
    if (static_cast<int64_t>(voxel.count) < options_.min_points_per_voxel) continue;
    const double n = voxel.count;
    const Eigen::Vector3d offset(voxel.offset_sum[0], voxel.offset_sum[1], voxel.offset_sum[2]);
    Eigen::Vector3d position = voxelCentre(key) + offset / n;
    Eigen::Vector3d normal(voxel.normal_sum[0], voxel.normal_sum[1], voxel.normal_sum[2]);
    const double normal_length = normal.norm();
    // Opposing normals that cancel give no direction: report zero, not NaN.
    normal = normal_length > 1e-6 * n ? Eigen::Vector3d(normal / normal_length)
                                      : Eigen::Vector3d::Zero();
    const Eigen::Vector3f position_f = position.cast<float>();
    if (!position_f.allFinite()) continue;  // cannot happen for finite input; never emit it
    cloud.points.push_back(position_f);
    cloud.normals.push_back(normal.cast<float>());
    cloud.colors.push_back({clampColor(voxel.rgb_sum[0] / n), clampColor(voxel.rgb_sum[1] / n),
                            clampColor(voxel.rgb_sum[2] / n)});
    const double confidence = voxel.confidence_sum / n;
    cloud.confidence.push_back(std::isfinite(confidence) ? static_cast<float>(confidence) : 0.f);
    cloud.counts.push_back(voxel.count);
  }
  return cloud;
}

}  // namespace amhmvs
