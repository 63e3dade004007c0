// Internal interface between DepthEstimator and its backends.
#pragma once

#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/patchmatch_pixel.h"

namespace amhmvs {
namespace mvs {

// Kernel parameters of a validated problem.
PatchMatchParams makePatchMatchParams(const PatchMatchOptions& options,
                                      const DepthProblem& problem);

DepthMap estimateOnCpu(const PatchMatchOptions& options, const PatchMatchParams& params,
                       const DepthProblem& problem);
DepthMap estimateOnCuda(const PatchMatchOptions& options, const PatchMatchParams& params,
                        const DepthProblem& problem);
bool cudaDeviceUsable(std::string* description);

}  // namespace mvs
}  // namespace amhmvs
