// Internal interface between DepthEstimator and its backends.
#pragma once

#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/patchmatch_pixel.h"

namespace amhmvs {
namespace mvs {

// Kernel parameters of a validated problem.
PatchMatchParams makePatchMatchParams(const PatchMatchOptions& options,
                                      const DepthProblem& problem);

// The source depth maps of `problem` in one buffer (geometric term); sets
// each source's depth_offset in `P` (-1 stays where a source has none).
std::vector<float> concatenateSourceDepths(const DepthProblem& problem, PatchMatchParams* P);

DepthMap estimateOnCpu(const PatchMatchOptions& options, const PatchMatchParams& params,
                       const DepthProblem& problem);
// Device state of one estimator: image pool, work buffers, stream.
CudaState* createCudaState(const EstimatorResources& resources);
void destroyCudaState(CudaState* state);
// What an estimate's device outputs are: the result (kept, in one of two
// sets used in turn, until the estimate after next: cudaLastOutputs) or a
// coarser scale of a coarse-to-fine estimate (scratch, overwritten by the next).
// kResult: the estimate's result (the device outputs a consumer may read);
// kIntermediate: a coarser scale's (its images in the coarser pool);
// kFirstPass: a full-size first pass that a second one refines.
enum class CudaOutputUse { kResult, kIntermediate, kFirstPass };
DepthMap estimateOnCuda(CudaState& state, const PatchMatchOptions& options, const PatchMatchParams& params,
                        const DepthProblem& problem, CudaOutputUse use);
void forgetOnCuda(CudaState& state, int64_t key);
void forgetAllOnCuda(CudaState& state);
DeviceCacheStats cudaCacheStats(const CudaState& state);
DeviceDepthMap cudaLastOutputs(const CudaState& state);
bool cudaDeviceUsable(std::string* description);

}  // namespace mvs
}  // namespace amhmvs
