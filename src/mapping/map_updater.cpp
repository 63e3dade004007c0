#include "amhmvs_mapping/mapping/map_updater.h"

#include <chrono>
#include <functional>
#include <utility>

#include "amhmvs_mapping/core/stopwatch.h"

namespace amhmvs {

MapUpdater::~MapUpdater() {
  try {
    finish();
  } catch (...) {
    // Nothing to report to at destruction; the map is discarded anyway.
  }
}

void MapUpdater::add(int64_t id, const Eigen::Isometry3d& pose, Shared<KeyframePoints> points, bool in_background) {
  finish();  // one update at a time, in order
  std::function<MapUpdateRecord()> update = [this, id, pose, points = std::move(points)]() {
    const auto start = std::chrono::steady_clock::now();
    MapUpdateRecord record;
    record.id = id;
    record.update = map_.addKeyframe(id, pose, points);
    record.milliseconds = millisecondsSince(start);
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
  if (!map_.contains(id)) return false;
  map_.removeKeyframe(id);
  noteChanged();
  return true;
}

bool MapUpdater::updatePose(int64_t id, const Eigen::Isometry3d& pose) {
  finish();
  if (!map_.contains(id)) return false;
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

void MapUpdater::reset(const VoxelMapOptions& options) {
  try {
    finish();
  } catch (const std::exception&) {
    // The map is emptied anyway.
  }
  finished_.clear();
  map_ = VoxelMap(options);
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

std::vector<MapUpdateRecord> MapUpdater::takeUpdates() {
  std::vector<MapUpdateRecord> taken;
  taken.swap(finished_);
  return taken;
}

}  // namespace amhmvs
