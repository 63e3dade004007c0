// Depth estimation that survives a failing backend (GPU out of memory, lost
// device): a BackendError of the primary estimate reruns that keyframe on the
// fallback (the CPU); after `switch_after` consecutive primary failures the
// primary is given up and every later keyframe goes to the fallback. Without
// a fallback (the primary is the CPU already) the error propagates and the
// caller drops the keyframe. InputError (a bad problem) always propagates:
// another backend would not fix it.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "amhmvs_mapping/mapping/online_mapper.h"

namespace amhmvs {

class FallbackEstimator {
 public:
  // Called with a readable line at each fallback and at the switch.
  using Report = std::function<void(const std::string&)>;

  // `fallback` may be empty (no fallback). Throws InputError for an empty
  // primary or switch_after < 1.
  FallbackEstimator(EstimateFunction primary, EstimateFunction fallback, int switch_after, Report report);

  DepthMap operator()(const DepthProblem& problem);

  bool switched() const { return switched_; }        // the primary was given up
  size_t fallbacks() const { return fallbacks_; }    // keyframes rerun on the fallback

 private:
  EstimateFunction primary_, fallback_;
  int switch_after_;
  Report report_;
  int consecutive_failures_ = 0;
  bool switched_ = false;
  size_t fallbacks_ = 0;
};

}  // namespace amhmvs
