// Stand-in for the CUDA backend in builds without nvcc.
#include "amhmvs_mapping/core/error.h"
#include "backends.h"

namespace amhmvs {
namespace mvs {

bool cudaDeviceUsable(std::string* description) {
  if (description) *description = "this build has no CUDA backend (nvcc was not found)";
  return false;
}

// Never called: DepthEstimator refuses kCuda when cudaDeviceUsable() is false.
class CudaState {};
CudaState* createCudaState(const EstimatorResources&) {
  throw BackendError("this build has no CUDA backend (nvcc was not found)");
}
void destroyCudaState(CudaState* state) { delete state; }
DepthMap estimateOnCuda(CudaState&, const PatchMatchOptions&, const PatchMatchParams&, const DepthProblem&,
                        CudaOutputUse) {
  throw BackendError("this build has no CUDA backend (nvcc was not found)");
}
void forgetOnCuda(CudaState&, int64_t) {}
void forgetAllOnCuda(CudaState&) {}
DeviceCacheStats cudaCacheStats(const CudaState&) { return {}; }
DeviceDepthMap cudaLastOutputs(const CudaState&) { return {}; }

}  // namespace mvs
}  // namespace amhmvs
