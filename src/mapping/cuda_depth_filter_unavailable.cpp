// Stand-in for the CUDA depth filter in builds without nvcc.
#include "amhmvs_mapping/core/error.h"
#include "depth_filter_device.h"

namespace amhmvs {

std::unique_ptr<DeviceDepthFilter> makeCudaDepthFilter(const ImageU8&, const ImageF&,
                                                       const std::vector<filter::DepthBelief>&) {
  throw BackendError("this build has no CUDA backend (nvcc was not found)");
}

}  // namespace amhmvs
