// The online mapper's rolling-shutter part (rolling_shutter.h has the
// per-image rectification): which angular velocity each stored keyframe's
// image is rectified with. A keyframe just stored is rectified with the
// motion from the keyframe stored before it (at most max_interval_s
// earlier). The first keyframe of a run, which had no motion to go by, is
// rectified with the second's motion while nothing has read its image yet.
#pragma once

#include <cstdint>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"

namespace amhmvs {

class RollingShutterRectifier {
 public:
  void setOptions(const RollingShutterOptions& options) { options_ = options; }

  // Rectifies keyframe `id`, just stored, in the store. `estimates_started`:
  // the mapper's count of estimates begun (unchanged since the previous
  // keyframe was stored: nothing has read that one's image).
  void rectifyStored(int64_t id, uint64_t estimates_started, KeyframeStore* store);
  void reset();

  size_t rectified() const { return rectified_; }
  size_t notRectified() const { return not_rectified_; }

 private:
  RollingShutterOptions options_;
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
  size_t rectified_ = 0;
  size_t not_rectified_ = 0;
};

}  // namespace amhmvs
