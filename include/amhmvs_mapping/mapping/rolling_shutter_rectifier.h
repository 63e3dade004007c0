// The online mapper's rolling-shutter part (rolling_shutter.h has the
// per-image rectification): which angular velocity each stored keyframe's
// image is rectified with, and when an image is rectified again.
//
// - A keyframe just stored is rectified with the tracker's velocity when it
//   has one (use_tracker_velocity), else with the motion from the keyframe
//   stored before it (at most max_interval_s earlier). The first keyframe of
//   a run, which had no motion to go by, is rectified with the second's
//   motion while nothing has read its image yet.
// - With the keyframe bundle adjustment (from_adjusted_poses, or the
//   tracker's velocity solved), each keyframe's unrectified image is kept;
//   after an adjustment, keyframes whose adjusted velocity differs from the
//   one their image is rectified with by more than a few hundredths of a
//   pixel over a readout are due, and rectifyDueAgain() replaces their
//   images. Their image revision counts how often.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"

namespace amhmvs {

// A keyframe image rectified again: the velocity it had been rectified with and the new one.
struct ImageRectifiedAgain {
  int64_t id = 0;
  PinholeCamera camera;
  Eigen::Vector3d used = Eigen::Vector3d::Zero();
  Eigen::Vector3d wanted = Eigen::Vector3d::Zero();
};

class RollingShutterRectifier {
 public:
  // `adjusted`: the keyframe bundle adjustment runs (images may be rectified again).
  void setOptions(const RollingShutterOptions& options, bool adjusted);

  // Rectifies keyframe `id`, just stored, in the store. `estimates_started`:
  // the mapper's count of estimates begun (unchanged since the previous
  // keyframe was stored: nothing has read that one's image).
  void rectifyStored(int64_t id, uint64_t estimates_started, KeyframeStore* store);

  // Whether a keyframe's depth map may still be estimated again (else its
  // image stays as it was estimated from).
  using ReestimatePredicate = std::function<bool(int64_t id)>;
  // The priors of the keyframes whose tracker's velocity the adjustment solves.
  std::map<int64_t, VelocityPrior> velocityPriors(const KeyframeStore& store) const;
  // After an adjustment: the keyframes whose solved velocity corrections, or
  // whose chords between adjusted poses, differ from their rectification are due.
  void planFromVelocities(const std::map<int64_t, CameraVelocity>& corrections, const KeyframeStore& store,
                          const ReestimatePredicate& reestimates_left);
  void planFromPoses(const std::map<int64_t, Eigen::Isometry3d>& poses, const KeyframeStore& store,
                     const ReestimatePredicate& reestimates_left);
  // Replaces the due keyframes' images in the store; returns them, in id
  // order, so that their features and resident copies follow.
  std::vector<ImageRectifiedAgain> rectifyDueAgain(KeyframeStore* store);

  // How often a keyframe's image was rectified again (0 when never).
  int imageRevision(int64_t id) const;
  void forget(int64_t id);
  void reset();

  size_t rectified() const { return rectified_; }
  size_t notRectified() const { return not_rectified_; }
  size_t fromTrackerVelocity() const { return from_tracker_velocity_; }
  size_t rectifiedAgain() const { return rectified_again_; }

 private:
  RollingShutterOptions options_;
  bool adjusted_ = false;
  // The last keyframe stored: the motion to the next one gives that one's angular velocity.
  struct MotionAnchor {
    bool set = false;
    int64_t id = 0;
    double stamp = 0;
    PinholeCamera camera;
    bool rectified = false;
    uint64_t estimates_started = 0;  // unchanged when the next is stored: nothing read its image
  };
  MotionAnchor motion_anchor_;
  // Keyframes whose image may be rectified again, kept as they came with the
  // angular velocity their stored image is rectified with: those rectified
  // from chords (from_adjusted_poses) and, with solvesTrackerVelocity(), those
  // rectified with the tracker's velocity, which they keep as their prior.
  struct Rerectifiable {
    ImageU8 unrectified;
    Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
    std::optional<CameraVelocity> tracker_velocity;  // set: its velocity is solved
  };
  std::map<int64_t, Rerectifiable> rerectifiable_;
  struct Rectification {
    Eigen::Vector3d angular_velocity;
    std::optional<Eigen::Vector3d> linear_velocity;  // set: the rows' centres move with this
  };
  std::map<int64_t, Rectification> due_;  // to be rectified again, with this velocity
  std::map<int64_t, int> image_revisions_;
  size_t rectified_ = 0;
  size_t not_rectified_ = 0;
  size_t from_tracker_velocity_ = 0;
  size_t rectified_again_ = 0;
};

}  // namespace amhmvs
