#pragma once

#include <cstdint>
#include <future>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/serial_worker.h"
#include "amhmvs_mapping/core/shared.h"
#include "amhmvs_mapping/mapping/tsdf_map.h"
#include "amhmvs_mapping/mapping/voxel_map.h"

namespace amhmvs {

struct MapUpdateRecord {
  int64_t id = 0;          // the keyframe added (or replaced)
  VoxelMapUpdate update;
  TsdfMapUpdate surface;    // when the surface map took the keyframe's depth
  double milliseconds = 0;  // the update itself (on the worker thread when in the background)
  // Both maps after the update: heap bytes, keyframe points kept for re-posing, surface blocks.
  size_t memory_bytes = 0;
  size_t kept_points = 0;
  size_t surface_blocks = 0;
};

// The voxel map and the surface map (when enabled), and their updates,
// applied in order. An added keyframe may be
// merged on a worker thread so that the next estimate overlaps it; every
// other access first waits for that update (one in flight at most), so the
// map is never read while it changes. The revision counts changes: outputs
// republish the map when it moves.
class MapUpdater {
 public:
  MapUpdater(const VoxelMapOptions& options, const TsdfMapOptions& surface);
  ~MapUpdater();  // waits for the update in flight
  MapUpdater(const MapUpdater&) = delete;
  MapUpdater& operator=(const MapUpdater&) = delete;

  // Adds (or replaces) a keyframe's points at `pose`, and its depth in the
  // surface map when that is enabled and `surface` has depth (its mesh is
  // extracted where it changed when it is read); in the background when asked.
  void add(int64_t id, const Eigen::Isometry3d& pose, Shared<KeyframePoints> points, Shared<SurfaceDepth> surface,
           bool in_background);
  bool remove(int64_t id);  // false: it was not in the map
  bool updatePose(int64_t id, const Eigen::Isometry3d& pose);  // false: it is not in the map
  void setMinPointsPerVoxel(int min_points);
  void replace(VoxelMap map);  // e.g. rebuilt at another voxel size
  void reset(const VoxelMapOptions& options, const TsdfMapOptions& surface);  // empty; updates in flight are discarded

  // Waits for the update in flight; rethrows what it threw.
  void finish() const;
  const VoxelMap& map() const;  // after finish()
  const TsdfMap* surface() const;  // after finish(); null when the surface map is off
  std::vector<MapUpdateRecord> takeUpdates();  // finished since the last call
  size_t voxelCount() const { return voxel_count_; }  // as of the last finished update
  uint64_t revision() const { return revision_; }

 private:
  void noteChanged();

  VoxelMap map_;
  std::unique_ptr<TsdfMap> surface_;  // when enabled
  mutable std::future<MapUpdateRecord> work_;
  std::unique_ptr<SerialWorker> worker_;  // created with the first background update
  mutable std::vector<MapUpdateRecord> finished_;
  mutable size_t voxel_count_ = 0;
  uint64_t revision_ = 0;
};

}  // namespace amhmvs
