#include "amhmvs_mapping/mapping/keyframe_store.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <tuple>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

std::string keyframeName(int64_t id) { return "keyframe " + std::to_string(id); }

size_t depthMapBytes(const DepthMap& depth) {
  return imageBytes(depth.depth) + imageBytes(depth.normal) + imageBytes(depth.cost);
}

size_t payloadBytes(const StoredKeyframe& stored) {
  return imageBytes(stored.keyframe.image) + imageBytes(stored.gray_image) + depthMapBytes(stored.depth) +
         stored.keyframe.sparse_points.size() * sizeof(Eigen::Vector3d) +
         stored.points->size() * sizeof(KeyframePoint);
}

// Empty when `image` is a well-formed image of the camera's size with one of
// the allowed channel counts.
template <typename T>
std::string checkImage(const Image<T>& image, const PinholeCamera& camera, const char* what,
                       std::initializer_list<int> channels) {
  std::ostringstream why;
  if (!image.sameSize(camera.width, camera.height)) {
    why << what << " is " << image.width << "x" << image.height << " but its camera is "
        << camera.width << "x" << camera.height;
  } else if (std::find(channels.begin(), channels.end(), image.channels) == channels.end()) {
    why << what << " has " << image.channels << " channels";
  } else if (image.data.size() != image.pixelCount() * image.channels) {
    why << what << " holds " << image.data.size() << " values, expected "
        << image.pixelCount() * image.channels;
  }
  return why.str();
}

}  // namespace

std::string Keyframe::validate() const {
  std::ostringstream why;
  const std::string camera_problem = camera.validate();
  if (!camera_problem.empty()) {
    why << "camera: " << camera_problem;
  } else if (!std::isfinite(stamp)) {
    why << "stamp is not finite";
  } else if (image.empty()) {
    why << "image is empty";
  } else {
    why << checkImage(image, camera, "image", {1, 3});
  }
  if (why.tellp() == 0 && (depth_min != 0 || depth_max != 0) &&
      !(std::isfinite(depth_min) && std::isfinite(depth_max) && depth_min > 0 &&
        depth_min < depth_max)) {
    why << "depth range [" << depth_min << ", " << depth_max
        << "] must be unset (0, 0) or finite with 0 < min < max";
  }
  for (size_t i = 0; why.tellp() == 0 && i < sparse_points.size(); ++i) {
    if (!sparse_points[i].allFinite()) why << "sparse point " << i << " is not finite";
  }
  return why.str();
}

const char* keyframeStateName(KeyframeState state) {
  return state == KeyframeState::kPending ? "pending" : "done";
}

std::string KeyframeStoreOptions::validate() const {
  std::ostringstream why;
  if (max_keyframes == 0) why << "max_keyframes must be positive\n";
  if (max_bytes == 0) why << "max_bytes must be positive\n";
  return why.str();
}

KeyframeStore::KeyframeStore(const KeyframeStoreOptions& options) : options_(options) {
  const std::string why = options.validate();
  if (!why.empty()) throw InputError("keyframe store options: " + why);
}

KeyframeStore::Entry& KeyframeStore::find(int64_t id, const char* action) {
  const auto it = entries_.find(id);
  if (it == entries_.end()) {
    throw InputError(std::string("keyframe store: cannot ") + action + " " + keyframeName(id) +
                     ": unknown id (never added, removed or evicted)");
  }
  return it->second;
}

const KeyframeStore::Entry& KeyframeStore::find(int64_t id, const char* action) const {
  return const_cast<KeyframeStore*>(this)->find(id, action);
}

const StoredKeyframe& KeyframeStore::entry(int64_t id) const { return find(id, "look up").stored; }

std::vector<int64_t> KeyframeStore::add(Keyframe keyframe) {
  const int64_t id = keyframe.id;
  const std::string why = keyframe.validate();
  if (!why.empty()) throw InputError("keyframe store: " + keyframeName(id) + ": " + why);
  if (contains(id)) {
    throw InputError("keyframe store: " + keyframeName(id) + ": duplicate id (already stored)");
  }
  StoredKeyframe stored;
  stored.keyframe = std::move(keyframe);
  if (stored.keyframe.image.channels != 1) stored.gray_image = toGray(stored.keyframe.image);
  stored.bytes = payloadBytes(stored);
  if (stored.bytes > options_.max_bytes) {
    throw InputError("keyframe store: " + keyframeName(id) + ": needs " +
                     std::to_string(stored.bytes) + " bytes, more than the whole budget of " +
                     std::to_string(options_.max_bytes));
  }
  std::vector<int64_t> evicted = makeRoom(1, stored.bytes, id);
  bytes_ += stored.bytes;
  Entry& entry = entries_[id];
  entry.sequence = next_sequence_++;
  entry.stored = std::move(stored);
  entry.slot = centres_.size();
  centres_.push_back({entry.stored.keyframe.camera.center(), entry.sequence, id});
  order_[entry.sequence] = id;
  ++revision_;
  return evicted;
}

size_t KeyframeStore::bytesBeforePendingEvicted(const std::vector<int64_t>& spared) const {
  size_t room = options_.max_bytes > bytes_ ? options_.max_bytes - bytes_ : 0;
  for (const auto& [sequence, id] : order_) {
    if (sequence == order_.rbegin()->first) continue;  // the newest is spared
    const StoredKeyframe& stored = entries_.at(id).stored;
    const auto refs = source_refs_.find(id);
    const bool tier_one = stored.state == KeyframeState::kDone && (refs == source_refs_.end() || refs->second == 0);
    if (tier_one && std::find(spared.begin(), spared.end(), id) == spared.end())
      room += stored.bytes;
  }
  return room;
}

std::vector<int64_t> KeyframeStore::makeRoom(size_t extra_keyframes, size_t extra_bytes,
                                             int64_t keep_id) {
  const auto fits = [&](size_t count, size_t bytes) {
    return count + extra_keyframes <= options_.max_keyframes &&
           bytes + extra_bytes <= options_.max_bytes;
  };
  if (fits(entries_.size(), bytes_)) return {};

  // Plan first, so that an impossible request changes nothing.
  // The newest keyframe is spared: the one being added, else the last added.
  const int64_t newest_id =
      contains(keep_id) && !order_.empty() ? order_.rbegin()->second : keep_id;
  std::vector<std::tuple<int, uint64_t, int64_t>> candidates;  // (tier, sequence, id)
  for (const auto& [sequence, id] : order_) {
    if (id == keep_id || id == newest_id) continue;
    const StoredKeyframe& stored = entries_.at(id).stored;
    int tier = 3;
    if (stored.state == KeyframeState::kDone) {
      const auto refs = source_refs_.find(id);
      tier = (refs == source_refs_.end() || refs->second == 0) ? 1 : 2;
    }
    candidates.emplace_back(tier, sequence, id);
  }
  std::sort(candidates.begin(), candidates.end());
  size_t count = entries_.size(), bytes = bytes_;
  std::vector<int64_t> plan;
  for (const auto& candidate : candidates) {
    if (fits(count, bytes)) break;
    const int64_t id = std::get<2>(candidate);
    --count;
    bytes -= entries_.at(id).stored.bytes;
    plan.push_back(id);
  }
  if (!fits(count, bytes)) {
    throw InputError("keyframe store: " + keyframeName(keep_id) + ": " +
                     std::to_string(extra_bytes) + " more bytes do not fit the budget of " +
                     std::to_string(options_.max_bytes) +
                     " even after evicting all other keyframes but the newest");
  }
  for (int64_t id : plan) {
    erase(id);
    ++evicted_count_;
  }
  return plan;
}

void KeyframeStore::releaseSources(StoredKeyframe* stored) {
  for (int64_t source : stored->sources) {
    const auto refs = source_refs_.find(source);
    if (refs != source_refs_.end() && --refs->second <= 0) source_refs_.erase(refs);
  }
  stored->sources.clear();
}

void KeyframeStore::erase(int64_t id) {
  Entry& entry = entries_.at(id);
  releaseSources(&entry.stored);
  if (source_refs_.count(id) != 0) {
    // Pending keyframes lose this source and keep their others.
    for (auto& [other_id, other] : entries_) {
      auto& sources = other.stored.sources;
      sources.erase(std::remove(sources.begin(), sources.end(), id), sources.end());
    }
    source_refs_.erase(id);
  }
  bytes_ -= entry.stored.bytes;
  // The last centre takes the erased one's slot.
  centres_[entry.slot] = centres_.back();
  entries_.at(centres_[entry.slot].id).slot = entry.slot;
  centres_.pop_back();
  order_.erase(entry.sequence);
  entries_.erase(id);
  ++revision_;
}

void KeyframeStore::remove(int64_t id) {
  find(id, "remove");
  erase(id);
}

void KeyframeStore::setSources(int64_t id, const std::vector<int64_t>& source_ids) {
  Entry& entry = find(id, "set the sources of");
  if (entry.stored.state != KeyframeState::kPending) {
    throw InputError("keyframe store: cannot set the sources of " + keyframeName(id) +
                     ": its depth is already done");
  }
  for (int64_t source : source_ids) {
    if (source == id) {
      throw InputError("keyframe store: " + keyframeName(id) + " cannot be its own source");
    }
    if (!contains(source)) {
      throw InputError("keyframe store: source " + keyframeName(source) + " of " +
                       keyframeName(id) + " is not stored");
    }
  }
  releaseSources(&entry.stored);
  entry.stored.sources = source_ids;
  for (int64_t source : source_ids) ++source_refs_[source];
}

std::vector<int64_t> KeyframeStore::attachDepth(int64_t id, Shared<DepthMap> shared) {
  Entry& entry = find(id, "attach a depth map to");
  const PinholeCamera& camera = entry.stored.keyframe.camera;
  const DepthMap& depth = shared;
  std::string why = checkImage(depth.depth, camera, "depth map", {1});
  if (why.empty() && !depth.normal.empty())
    why = checkImage(depth.normal, camera, "normal map", {3});
  if (why.empty() && !depth.cost.empty()) why = checkImage(depth.cost, camera, "cost map", {1});
  if (why.empty() && depth.depth.empty()) why = "depth map is empty";
  if (!why.empty()) throw InputError("keyframe store: " + keyframeName(id) + ": " + why);

  const size_t old_bytes = depthMapBytes(entry.stored.depth);
  const size_t new_bytes = depthMapBytes(depth);
  std::vector<int64_t> evicted;
  if (new_bytes > old_bytes) evicted = makeRoom(0, new_bytes - old_bytes, id);
  Entry& kept = entries_.at(id);  // rehash-safe: erase() does not move other nodes
  kept.stored.depth = std::move(shared);
  static std::atomic<uint64_t> last_depth_revision{0};
  kept.stored.depth_revision = ++last_depth_revision;
  bytes_ = bytes_ - old_bytes + new_bytes;
  kept.stored.bytes = kept.stored.bytes - old_bytes + new_bytes;
  kept.stored.state = KeyframeState::kDone;
  releaseSources(&kept.stored);
  ++revision_;
  return evicted;
}

std::vector<int64_t> KeyframeStore::attachPoints(int64_t id, Shared<KeyframePoints> points) {
  Entry& entry = find(id, "attach points to");
  const size_t old_bytes = entry.stored.points->size() * sizeof(KeyframePoint);
  const size_t new_bytes = points->size() * sizeof(KeyframePoint);
  std::vector<int64_t> evicted;
  if (new_bytes > old_bytes) evicted = makeRoom(0, new_bytes - old_bytes, id);
  Entry& kept = entries_.at(id);
  kept.stored.points = std::move(points);
  bytes_ = bytes_ - old_bytes + new_bytes;
  kept.stored.bytes = kept.stored.bytes - old_bytes + new_bytes;
  return evicted;
}

void KeyframeStore::replaceImage(int64_t id, ImageU8 image) {
  Entry& entry = find(id, "replace the image of");
  Keyframe& keyframe = entry.stored.keyframe;
  if (image.width != keyframe.image.width || image.height != keyframe.image.height ||
      image.channels != keyframe.image.channels) {
    throw InputError("keyframe store: new image of " + keyframeName(id) + " is " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + "x" + std::to_string(image.channels) + ", the stored one " +
                     std::to_string(keyframe.image.width) + "x" + std::to_string(keyframe.image.height) + "x" +
                     std::to_string(keyframe.image.channels));
  }
  keyframe.image = std::move(image);
  if (keyframe.image.channels != 1) entry.stored.gray_image = toGray(keyframe.image);
  ++revision_;
}

void KeyframeStore::updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  Entry& entry = find(id, "update the pose of");
  const std::string why = validateRigidPose(camera_to_world);
  if (!why.empty()) {
    throw InputError("keyframe store: new pose of " + keyframeName(id) + ": " + why);
  }
  Keyframe& keyframe = entry.stored.keyframe;
  // Sparse points move with the keyframe: world' = T_new * T_old^-1 * world.
  const Eigen::Isometry3d motion = camera_to_world * keyframe.cameraToWorld().inverse();
  for (Eigen::Vector3d& point : keyframe.sparse_points) point = motion * point;
  keyframe.setCameraToWorld(camera_to_world);
  centres_[entry.slot].position = keyframe.camera.center();
  ++entry.stored.pose_revision;
  ++revision_;
}

std::vector<int64_t> KeyframeStore::ids() const {
  std::vector<int64_t> out;
  out.reserve(order_.size());
  for (const auto& entry : order_) out.push_back(entry.second);
  return out;
}

std::vector<int64_t> KeyframeStore::nearestIds(const Eigen::Vector3d& point, size_t count, int64_t skip_id,
                                               const std::function<bool(const StoredKeyframe&)>& accept) const {
  std::vector<std::tuple<double, uint64_t, int64_t>> heap;  // (squared distance, sequence, id)
  heap.reserve(centres_.size());
  for (const Centre& centre : centres_) {
    if (centre.id != skip_id) heap.emplace_back((centre.position - point).squaredNorm(), centre.sequence, centre.id);
  }
  const auto farther = [](const auto& a, const auto& b) { return a > b; };
  std::make_heap(heap.begin(), heap.end(), farther);
  std::vector<int64_t> nearest;
  while (nearest.size() < count && !heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), farther);
    const int64_t id = std::get<2>(heap.back());
    heap.pop_back();
    if (!accept || accept(entries_.at(id).stored)) nearest.push_back(id);
  }
  return nearest;
}

std::vector<int64_t> KeyframeStore::pendingIds() const {
  std::vector<int64_t> out;
  for (const auto& entry : order_) {
    if (entries_.at(entry.second).stored.state == KeyframeState::kPending) {
      out.push_back(entry.second);
    }
  }
  return out;
}

}  // namespace amhmvs
