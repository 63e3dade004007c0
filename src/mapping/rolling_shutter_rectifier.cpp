#include "amhmvs_mapping/mapping/rolling_shutter_rectifier.h"

namespace amhmvs {

void RollingShutterRectifier::rectifyStored(int64_t id, uint64_t estimates_started, KeyframeStore* store) {
  if (!options_.enabled()) return;
  const Keyframe& stored = store->keyframe(id);
  const MotionAnchor previous = motion_anchor_;
  motion_anchor_ = {true, id, stored.stamp, stored.camera, false, estimates_started};
  const double interval = stored.stamp - previous.stamp;
  if (!previous.set || !(interval > 0) || interval > options_.max_interval_s) {
    ++not_rectified_;
    return;
  }
  const Eigen::Vector3d angular_velocity = cameraAngularVelocity(previous.camera, stored.camera, interval);
  const auto rectifyInStore = [&](int64_t key) {
    const Keyframe& keyframe = store->keyframe(key);
    store->replaceImage(key, rectifyRollingShutter(keyframe.image, keyframe.camera, angular_velocity,
                                                   options_.readout_s));
    ++rectified_;
  };
  rectifyInStore(id);
  motion_anchor_.rectified = true;
  // The first keyframe of a run had no motion to go by; nothing has read its image yet.
  if (!previous.rectified && previous.estimates_started == estimates_started && store->contains(previous.id)) {
    rectifyInStore(previous.id);
    --not_rectified_;
  }
}

void RollingShutterRectifier::reset() {
  const RollingShutterOptions options = options_;
  *this = RollingShutterRectifier();
  setOptions(options);
}

}  // namespace amhmvs
