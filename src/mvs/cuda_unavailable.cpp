// Stand-in for the CUDA backend in builds without nvcc.
#include "amhmvs_mapping/core/error.h"
#include "backends.h"

namespace amhmvs {
namespace mvs {

bool cudaDeviceUsable(std::string* description) {
  if (description) *description = "this build has no CUDA backend (nvcc was not found)";
  return false;
}

DepthMap estimateOnCuda(const PatchMatchOptions&, const PatchMatchParams&, const DepthProblem&) {
  throw BackendError("this build has no CUDA backend (nvcc was not found)");
}

}  // namespace mvs
}  // namespace amhmvs
