// The keyframe bundle adjustment in builds without Ceres: nothing solved.
#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"

namespace amhmvs {

bool keyframeBundleAdjustmentAvailable() { return false; }

KeyframeBundleAdjustmentResult adjustKeyframes(const std::map<int64_t, BundleKeyframe>&,
                                               const std::vector<KeyframeFeatureMatches>&,
                                               const KeyframeBundleAdjustmentSettings&) {
  return {};
}

}  // namespace amhmvs
