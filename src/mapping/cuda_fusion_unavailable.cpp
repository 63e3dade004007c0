// Stand-in for the CUDA fusion backend in builds without nvcc.
#include "amhmvs_mapping/core/error.h"
#include "fusion_driver.h"

namespace amhmvs {
namespace fusion {

std::unique_ptr<ReferenceFusion> makeCudaReferenceFusion(const FuserResources&) {
  throw BackendError("this build has no CUDA backend (nvcc was not found)");
}

}  // namespace fusion
}  // namespace amhmvs
