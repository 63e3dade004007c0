// The relative poses between keyframes that the pose refinement found
// (pose_refinement.h), kept for the fusion's consistency check and the
// confidence's agreement count: a keyframe's depth map is checked against
// its neighbours' at the relative poses its stereo used, not at the
// tracker's, whose few pixels of error would reject correct depth. The
// fused points and published depth stay at the tracker's pose.
//
// A pair is kept as the source's pose relative to the reference (not as
// world poses), so that it stays valid when the tracker moves both
// keyframes (a loop closure's pose updates).
#pragma once

#include <cstdint>
#include <map>
#include <utility>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs {

class RefinedRelativePoses {
 public:
  // Records `source`'s refined camera relative to `reference`'s camera (the
  // one the refinement held fixed); replaces an earlier record of the pair.
  void record(int64_t reference, const PinholeCamera& reference_camera, int64_t source,
              const PinholeCamera& refined_source_camera);
  // Drops the pair's record (a later refinement kept the tracker's pose).
  void drop(int64_t reference, int64_t source);
  // `view`'s camera (intrinsics kept) at its recorded pose relative to
  // `reference`, placed at `reference_camera`'s pose; either direction of
  // the pair serves. False, `camera` untouched, when the pair has no record.
  bool place(int64_t reference, const PinholeCamera& reference_camera, int64_t view, PinholeCamera* camera) const;
  // Forgets every pair with the keyframe (it left the store).
  void forget(int64_t id);
  void clear() { poses_.clear(); }
  // Every pair: (reference, source) -> source-from-reference transform.
  const std::map<std::pair<int64_t, int64_t>, Eigen::Isometry3d>& pairs() const { return poses_; }
  size_t size() const { return poses_.size(); }

 private:
  // (reference, source) -> source-from-reference transform: X_source = T * X_reference.
  std::map<std::pair<int64_t, int64_t>, Eigen::Isometry3d> poses_;
};

}  // namespace amhmvs
