// A KeyframeDepthFilter's beliefs on the GPU (cuda/cuda_depth_filter.cu): one
// thread per pixel runs filter::filterPixel, the CPU loop's code. The
// keyframe's image, normals and beliefs stay on the device across frames.
#pragma once

#include <memory>
#include <vector>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/depth_filter.h"

namespace amhmvs {

class DeviceDepthFilter {
 public:
  virtual ~DeviceDepthFilter() = default;
  // One frame (its grey image) with the constants of frameParams().
  virtual DepthFilterUpdate update(const filter::FrameParams& params, const ImageU8& gray) = 0;
  // The beliefs as they are now, in pixel order.
  virtual void download(std::vector<filter::DepthBelief>* beliefs) = 0;
};

// Throws BackendError in builds without CUDA or without a usable GPU.
std::unique_ptr<DeviceDepthFilter> makeCudaDepthFilter(const ImageU8& keyframe_gray, const ImageF& normal,
                                                       const std::vector<filter::DepthBelief>& beliefs);

}  // namespace amhmvs
