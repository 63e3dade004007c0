// PoseRefiner in builds without OpenCV features2d or Ceres (the core-only
// build of the GPU machine): refine() changes nothing and says why.
#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"

namespace amhmvs {

class PoseRefiner::Impl {};

bool PoseRefiner::available() { return false; }

PoseRefiner::PoseRefiner(const PoseRefinementOptions& options) : options_(options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("pose refinement options:\n" + problems);
}

PoseRefiner::~PoseRefiner() = default;

PoseRefinementResult PoseRefiner::refine(DepthProblem*) {
  PoseRefinementResult result;
  result.note = unavailableMessage();
  return result;
}

KeyframeBundleAdjustmentResult PoseRefiner::adjustKeyframes(const std::map<int64_t, PinholeCamera>&) const {
  return {};
}

void PoseRefiner::forget(int64_t) {}
void PoseRefiner::forgetAll() {}
size_t PoseRefiner::cachedImages() const { return 0; }

}  // namespace amhmvs
