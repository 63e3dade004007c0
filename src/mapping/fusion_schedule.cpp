#include "amhmvs_mapping/mapping/fusion_schedule.h"

#include <algorithm>

namespace amhmvs {

void FusionSchedule::wait(int64_t id) {
  if (!isWaiting(id)) waiting_.push_back(id);
}

bool FusionSchedule::isWaiting(int64_t id) const {
  return std::find(waiting_.begin(), waiting_.end(), id) != waiting_.end();
}

bool FusionSchedule::fuse(int64_t id, const std::vector<int64_t>& views, bool too_few) {
  const auto waiting = std::find(waiting_.begin(), waiting_.end(), id);
  if (waiting != waiting_.end()) waiting_.erase(waiting);
  Fusion& fusion = fusions_[id];
  fusion.underfused_views = too_few ? views.size() : 0;
  fusion.rechecks_left = too_few ? kRechecks : 0;
  fusion.views_checked = false;
  const bool again = fusion.fused;
  fusion.fused = true;
  fusion.fused_with = views;
  fusion.fused_against_replaced_map = false;
  return again;
}

void FusionSchedule::depthMapChecked() {
  for (auto& [id, fusion] : fusions_) {
    if (fusion.rechecks_left <= 0) continue;
    fusion.views_checked = false;  // a new depth map may be a new view
    if (--fusion.rechecks_left <= 0) fusion.underfused_views = 0;
  }
}

void FusionSchedule::posesChanged() {
  for (auto& [id, fusion] : fusions_) fusion.views_checked = false;
}

std::vector<int64_t> FusionSchedule::underfusedToCheck() const {
  std::vector<int64_t> ids;
  for (const auto& [id, fusion] : fusions_)
    if (fusion.rechecks_left > 0 && !fusion.views_checked && !isWaiting(id)) ids.push_back(id);
  return ids;
}

size_t FusionSchedule::underfusedViews(int64_t id) const {
  const auto found = fusions_.find(id);
  return found == fusions_.end() ? 0 : found->second.underfused_views;
}

void FusionSchedule::markChecked(int64_t id) {
  const auto found = fusions_.find(id);
  if (found != fusions_.end()) found->second.views_checked = true;
}

void FusionSchedule::depthMapReplaced(int64_t id) {
  for (auto& [other, fusion] : fusions_) {
    if (other != id && fusion.fused &&
        std::find(fusion.fused_with.begin(), fusion.fused_with.end(), id) != fusion.fused_with.end())
      fusion.fused_against_replaced_map = true;
  }
}

std::optional<int64_t> FusionSchedule::takeFusedAgainstReplaced() {
  for (auto& [id, fusion] : fusions_) {
    if (!fusion.fused_against_replaced_map) continue;
    fusion.fused_against_replaced_map = false;
    if (!isWaiting(id)) return id;
  }
  return std::nullopt;
}

bool FusionSchedule::forget(int64_t id) {
  fusions_.erase(id);
  const auto waiting = std::find(waiting_.begin(), waiting_.end(), id);
  if (waiting == waiting_.end()) return false;
  waiting_.erase(waiting);
  return true;
}

void FusionSchedule::clear() {
  waiting_.clear();
  fusions_.clear();
}

}  // namespace amhmvs
