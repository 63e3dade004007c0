#include "amhmvs_mapping/mapping/fallback_estimator.h"

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

FallbackEstimator::FallbackEstimator(EstimateFunction primary, EstimateFunction fallback, int switch_after,
                                     Report report)
    : primary_(std::move(primary)), fallback_(std::move(fallback)), switch_after_(switch_after),
      report_(std::move(report)) {
  if (!primary_) throw InputError("fallback estimator: no primary estimate function");
  if (switch_after_ < 1) throw InputError("fallback estimator: switch_after must be >= 1");
}

DepthMap FallbackEstimator::operator()(const DepthProblem& problem) {
  if (!switched_) {
    try {
      DepthMap map = primary_(problem);
      consecutive_failures_ = 0;
      return map;
    } catch (const BackendError& e) {
      if (!fallback_) throw;
      ++consecutive_failures_;
      ++fallbacks_;
      switched_ = consecutive_failures_ >= switch_after_;
      if (report_)
        report_(std::string("backend failed (") + e.what() + "): this keyframe runs on the fallback" +
                (switched_ ? "; " + std::to_string(consecutive_failures_) +
                                 " failures in a row, every later keyframe too"
                           : ""));
    }
  }
  if (!fallback_) throw BackendError("fallback estimator: no fallback");
  return fallback_(problem);
}

}  // namespace amhmvs
