// Bounded store of the keyframes that the online mapper keeps: their images,
// cameras (intrinsics + pose, updatable at any time for loop closures),
// optional depth ranges and sparse SLAM points, and their results (depth map,
// dense points) once computed.
//
//   KeyframeStore store(options);
//   std::vector<int64_t> evicted = store.add(std::move(keyframe));
//   store.setSources(id, source_ids);         // while its depth is pending
//   store.attachDepth(id, std::move(depth));  // marks it done
//   store.updatePose(id, camera_to_world);    // loop closure
//
// Memory bound: at most options.max_keyframes keyframes and options.max_bytes
// payload bytes (see StoredKeyframe::bytes). When an add or an attachment
// would exceed a bound, keyframes are evicted in this order, each tier oldest
// (earliest added) first, until it fits:
//   1. done keyframes that are no source of a pending keyframe;
//   2. done keyframes that are sources of pending keyframes (those keyframes
//      lose a source and keep the others);
//   3. pending keyframes (their depth is never computed).
// The keyframe being added or given an attachment is never evicted; when it
// alone exceeds max_bytes, the call throws InputError and nothing changes.
// Every call that may evict returns the evicted ids (oldest first), so that
// the caller can drop them elsewhere too.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/core/shared.h"
#include "amhmvs_mapping/mapping/voxel_map.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct Keyframe {
  int64_t id = 0;
  double stamp = 0;      // seconds (a label: arrival order decides; a clock may have jumped back)
  ImageU8 image;         // grey (1 channel) or RGB (3), size of the camera
  PinholeCamera camera;  // intrinsics and world-to-camera pose
  // Optional z-depth range of the scene in this view (e.g. from the SLAM
  // front end); used when both are > 0.
  double depth_min = 0, depth_max = 0;
  std::vector<Eigen::Vector3d> sparse_points;  // optional SLAM points, world frame

  bool hasDepthRange() const { return depth_min > 0 && depth_max > 0; }
  Eigen::Isometry3d cameraToWorld() const { return amhmvs::cameraToWorld(camera); }
  void setCameraToWorld(const Eigen::Isometry3d& pose) { amhmvs::setCameraToWorld(pose, &camera); }

  // Empty when the keyframe is usable: valid camera (positive focal, finite
  // rigid pose), image of the camera's size with 1 or 3 channels, finite
  // stamp, finite sparse points, depth range unset or 0 < min < max.
  std::string validate() const;
};

enum class KeyframeState { kPending, kDone };
const char* keyframeStateName(KeyframeState state);

struct StoredKeyframe {
  Keyframe keyframe;
  KeyframeState state = KeyframeState::kPending;
  // The image as the estimator reads it (8-bit grey), converted once when the
  // keyframe is added; empty when the keyframe's image is grey already.
  ImageU8 gray_image;
  const ImageU8& grayImage() const { return gray_image.empty() ? keyframe.image : gray_image; }
  std::vector<int64_t> sources;  // source keyframes chosen while pending
  // Shared with the result that reported them and the voxel map (no copy).
  Shared<DepthMap> depth;          // empty until attachDepth()
  Shared<KeyframePoints> points;   // dense points, camera frame; empty until attachPoints()
  uint64_t pose_revision = 0;    // incremented by each updatePose()
  // Unique in the process for each attached depth map (0: none yet), so that
  // a cache of depth maps (the GPU fuser's) never confuses two of them, even
  // across stores or after a reset.
  uint64_t depth_revision = 0;
  // Payload bytes counted against the budget: image (and its grey copy) + depth map images
  // (depth, normal, cost) + sparse points + dense points.
  size_t bytes = 0;
};

struct KeyframeStoreOptions {
  size_t max_keyframes = 500;
  size_t max_bytes = size_t{2} << 30;  // 2 GiB

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

class KeyframeStore {
 public:
  // Throws InputError when the options are invalid.
  explicit KeyframeStore(const KeyframeStoreOptions& options = KeyframeStoreOptions());

  // Adds a pending keyframe. Throws InputError (store unchanged) for an
  // invalid keyframe, a duplicate id, or a keyframe larger than max_bytes
  // alone. Returns evicted ids.
  std::vector<int64_t> add(Keyframe keyframe);

  // Records the sources chosen for a pending keyframe (protects them from
  // eviction tier 1). Throws InputError for an unknown or done keyframe, or
  // a source id that is unknown or the keyframe itself.
  void setSources(int64_t id, const std::vector<int64_t>& source_ids);

  // Attaches the keyframe's depth map and marks it done (its sources are
  // released). The depth image must have the camera's size; normal (3
  // channels) and cost, when present, too. Returns evicted ids. The store
  // shares the map with the caller (no copy).
  std::vector<int64_t> attachDepth(int64_t id, Shared<DepthMap> depth);
  // Attaches the keyframe's dense points (camera frame), shared. Returns
  // evicted ids.
  std::vector<int64_t> attachPoints(int64_t id, Shared<KeyframePoints> points);

  // Sets a new camera-to-world pose (pending or done keyframes). The sparse
  // points move rigidly with it (they were observed from this keyframe);
  // attachments are in the camera frame and stay valid. Throws InputError for
  // an unknown id or a non-finite / non-rigid pose.
  void updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world);
  // A new image of the same size and channels for a stored keyframe (its grey
  // copy follows); for corrections made before anything read the old one
  // (rolling_shutter.h). Throws InputError otherwise.
  void replaceImage(int64_t id, ImageU8 image);

  // Removes a keyframe; throws InputError for an unknown id.
  void remove(int64_t id);

  bool contains(int64_t id) const { return entries_.count(id) != 0; }
  // Throw InputError for an unknown id.
  const StoredKeyframe& entry(int64_t id) const;
  const Keyframe& keyframe(int64_t id) const { return entry(id).keyframe; }
  KeyframeState state(int64_t id) const { return entry(id).state; }

  std::vector<int64_t> ids() const;         // oldest first
  std::vector<int64_t> pendingIds() const;  // oldest first
  // The at most `count` keyframes whose camera centres lie nearest `point`
  // (nearest first, equal distances oldest first) among those that `accept`
  // passes (all when it is empty), skipping `skip_id`. One pass over a
  // contiguous array of the centres and `count` heap steps, so that a query
  // that selects sources or fusion views costs about the same in a store of
  // 50 keyframes and of 5,000.
  std::vector<int64_t> nearestIds(const Eigen::Vector3d& point, size_t count, int64_t skip_id,
                                  const std::function<bool(const StoredKeyframe&)>& accept = {}) const;
  // Bytes that attachments may add before an eviction would reach tier 2 or
  // 3 (a pending keyframe or one of its sources): the free budget plus the
  // tier-1 keyframes, without the newest and `spared` (keyframes about to be
  // given attachments, which are never evicted for their own).
  size_t bytesBeforePendingEvicted(const std::vector<int64_t>& spared) const;
  size_t size() const { return entries_.size(); }
  size_t bytes() const { return bytes_; }
  size_t evictedCount() const { return evicted_count_; }
  // Changes with every keyframe added, removed or evicted, depth map attached
  // or pose changed: what source selection reads (points and sources do not count).
  uint64_t revision() const { return revision_; }
  const KeyframeStoreOptions& options() const { return options_; }

 private:
  struct Entry {
    uint64_t sequence = 0;
    size_t slot = 0;  // in centres_
    StoredKeyframe stored;
  };
  // Every stored keyframe's camera centre, contiguous for nearestIds().
  struct Centre {
    Eigen::Vector3d position;
    uint64_t sequence = 0;
    int64_t id = 0;
  };
  Entry& find(int64_t id, const char* action);
  const Entry& find(int64_t id, const char* action) const;
  // Evicts until `extra_keyframes` more keyframes and `extra_bytes` more
  // bytes fit, sparing `keep_id`. Returns the evicted ids.
  std::vector<int64_t> makeRoom(size_t extra_keyframes, size_t extra_bytes, int64_t keep_id);
  void erase(int64_t id);
  void releaseSources(StoredKeyframe* stored);

  KeyframeStoreOptions options_;
  std::unordered_map<int64_t, Entry> entries_;
  std::map<uint64_t, int64_t> order_;             // sequence -> id, oldest first
  std::vector<Centre> centres_;                   // unordered; Entry::slot indexes it
  std::unordered_map<int64_t, int> source_refs_;  // id -> pending keyframes using it
  uint64_t next_sequence_ = 0;
  size_t bytes_ = 0;
  size_t evicted_count_ = 0;
  uint64_t revision_ = 0;
};

// Payload bytes of an image.
template <typename T>
size_t imageBytes(const Image<T>& image) {
  return image.data.size() * sizeof(T);
}

}  // namespace amhmvs
