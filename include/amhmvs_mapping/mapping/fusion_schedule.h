#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

namespace amhmvs {

// Where the fusion of each keyframe with a depth map stands (step 5 of
// online_mapper.h): the keyframes that wait for enough consistency views,
// oldest first, and of the fused ones those to be fused again: fused with
// fewer views than the confidence counts (while the next kRechecks depth
// maps may bring more), or against a depth map that a refinement replaced
// since. It decides nothing about views; the mapper asks and tells it.
class FusionSchedule {
 public:
  // Views that come later are near in time: a keyframe fused with too few
  // views looks for more during the next kRechecks depth maps only, so that
  // keyframes which never get more (a sparse stretch) cost nothing later.
  static constexpr int kRechecks = 8;

  // `id` has a new depth map: it waits for fusion (again, when refined).
  void wait(int64_t id);
  bool isWaiting(int64_t id) const;
  const std::vector<int64_t>& waiting() const { return waiting_; }

  // `id` leaves the queue and is fused now against `views`; `too_few`: with
  // fewer views than the confidence counts (fuse again when more see it).
  // True when it was fused before (its points are replaced).
  bool fuse(int64_t id, const std::vector<int64_t>& views, bool too_few);
  // A round of fusion checks after a depth map finished: each keyframe fused
  // with too few views has one recheck less, and is to be checked again.
  void depthMapChecked();
  // A pose changed: the views of every keyframe fused with too few are to
  // be checked again.
  void posesChanged();

  // Fused with too few views, not checked since the last depth map or pose
  // change, not waiting; lowest id first.
  std::vector<int64_t> underfusedToCheck() const;
  // How many views its last fusion had (0 when it is not underfused).
  size_t underfusedViews(int64_t id) const;
  void markChecked(int64_t id);

  // A refinement replaced `id`'s depth map: the keyframes fused against it
  // are to be fused again.
  void depthMapReplaced(int64_t id);
  // The next of those (lowest id; one that waits is skipped: it is fused
  // anyway), taken off the list.
  std::optional<int64_t> takeFusedAgainstReplaced();

  // Drops `id` (evicted, or its estimate failed). True when it waited.
  bool forget(int64_t id);
  void clear();

 private:
  struct Fusion {
    bool fused = false;               // once (even with no point): a later fusion is "again"
    std::vector<int64_t> fused_with;  // the consistency views of its last fusion
    // Fused with too few views: how many, rechecks left, checked since the last change.
    size_t underfused_views = 0;
    int rechecks_left = 0;
    bool views_checked = false;
    bool fused_against_replaced_map = false;
  };

  std::vector<int64_t> waiting_;  // oldest first
  std::map<int64_t, Fusion> fusions_;
};

}  // namespace amhmvs
