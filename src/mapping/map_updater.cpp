#include "amhmvs_mapping/mapping/map_updater.h"

#include <chrono>
#include <functional>
#include <utility>

#include "amhmvs_mapping/core/stopwatch.h"

namespace amhmvs {

MapUpdater::MapUpdater(const VoxelMapOptions& options, const TsdfMapOptions& surface) : map_(options) {
  if (surface.enabled) surface_.reset(new TsdfMap(surface));
}

MapUpdater::~MapUpdater() {
  try {
    finish();
  } catch (...) {
    // Nothing to report to at destruction; the map is discarded anyway.
  }
}

void MapUpdater::add(int64_t id, const Eigen::Isometry3d& pose, Shared<KeyframePoints> points,
                     Shared<SurfaceDepth> surface, bool in_background) {
  finish();  // one update at a time, in order
  std::function<MapUpdateRecord()> update = [this, id, pose, points = std::move(points),
                                             surface = std::move(surface)]() {
    const auto start = std::chrono::steady_clock::now();
    MapUpdateRecord record;
    record.id = id;
    record.update = map_.addKeyframe(id, pose, points);
    if (surface_ && !surface->depth.empty()) {
      record.surface = surface_->addKeyframe(id, pose, surface);
    } else if (surface_ && surface_->contains(id)) {
      surface_->removeKeyframe(id);  // fused again without a published depth
    }
    record.milliseconds = millisecondsSince(start);
    record.memory_bytes = map_.memoryBytes() + (surface_ ? surface_->memoryBytes() : 0);
    record.kept_points = map_.storedPointCount();
    record.surface_blocks = surface_ ? surface_->blockCount() : 0;
    return record;
  };
  if (in_background) {
    if (!worker_) worker_.reset(new SerialWorker());
    work_ = worker_->submit(std::move(update));
    ++revision_;  // the voxel count follows when the update finishes
  } else {
    finished_.push_back(update());
    noteChanged();
  }
}

bool MapUpdater::remove(int64_t id) {
  finish();
  const bool in_surface = surface_ && surface_->contains(id);
  if (in_surface) {
    surface_->removeKeyframe(id);
  }
  if (!map_.contains(id)) {
    if (in_surface) noteChanged();
    return in_surface;
  }
  map_.removeKeyframe(id);
  noteChanged();
  return true;
}

bool MapUpdater::updatePose(int64_t id, const Eigen::Isometry3d& pose) {
  finish();
  const bool in_surface = surface_ && surface_->contains(id);
  if (in_surface) {
    surface_->updatePose(id, pose);
  }
  if (!map_.contains(id)) {
    if (in_surface) noteChanged();
    return in_surface;
  }
  map_.updatePose(id, pose);
  noteChanged();
  return true;
}

void MapUpdater::setMinPointsPerVoxel(int min_points) {
  finish();
  map_.setMinPointsPerVoxel(min_points);
  noteChanged();
}

void MapUpdater::replace(VoxelMap map) {
  finish();
  map_ = std::move(map);
  noteChanged();
}

void MapUpdater::reset(const VoxelMapOptions& options, const TsdfMapOptions& surface) {
  try {
    finish();
  } catch (const std::exception&) {
    // The map is emptied anyway.
  }
  finished_.clear();
  map_ = VoxelMap(options);
  surface_.reset(surface.enabled ? new TsdfMap(surface) : nullptr);
  noteChanged();
}

void MapUpdater::noteChanged() {
  voxel_count_ = map_.voxelCount();
  ++revision_;
}

void MapUpdater::finish() const {
  if (!work_.valid()) return;
  MapUpdateRecord record = work_.get();  // rethrows what the update threw
  finished_.push_back(std::move(record));
  voxel_count_ = map_.voxelCount();
}

const VoxelMap& MapUpdater::map() const {
  finish();
  return map_;
}

const TsdfMap* MapUpdater::surface() const {
  finish();
  return surface_.get();
}

std::vector<MapUpdateRecord> MapUpdater::takeUpdates() {
  std::vector<MapUpdateRecord> taken;
  taken.swap(finished_);
  return taken;
}

}  // namespace amhmvs
