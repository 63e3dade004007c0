// CUDA backend of the temporal depth filter: filter::filterPixel, one thread
// per keyframe pixel, on buffers that live as long as the keyframe's filter.
#include <cuda_runtime.h>

#include "cuda_check.h"
#include "gpu_sampler.h"
#include "layered_texture.h"
#include "mapping/depth_filter_device.h"

namespace amhmvs {
namespace {

constexpr int kBlockX = 16, kBlockY = 8;

// counts: matched, missed, not visible.
__global__ void filterKernel(mvs::GpuSampler keyframe, const float* normals, filter::DepthBelief* beliefs,
                             filter::FrameParams params, unsigned long long* counts) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= keyframe.width || y >= keyframe.height) return;
  const int pixel = y * keyframe.width + x;
  const mvs::Vec3 normal{normals[3 * pixel], normals[3 * pixel + 1], normals[3 * pixel + 2]};
  mvs::ReferenceWindow window;
  filter::DepthBelief belief = beliefs[pixel];
  const filter::PixelOutcome outcome = filter::filterPixel<mvs::PaperWindow>(
      keyframe, keyframe.sourceView(0), params, normal, x, y, &window, &belief);
  beliefs[pixel] = belief;
  if (outcome == filter::PixelOutcome::kMatched) atomicAdd(&counts[0], 1ull);
  if (outcome == filter::PixelOutcome::kMissed) atomicAdd(&counts[1], 1ull);
  if (outcome == filter::PixelOutcome::kNotVisible) atomicAdd(&counts[2], 1ull);
}

class CudaDepthFilter : public DeviceDepthFilter {
 public:
  CudaDepthFilter(const ImageU8& gray, const ImageF& normal, const std::vector<filter::DepthBelief>& beliefs)
      : width_(gray.width), height_(gray.height), keyframe_(gray.data.size()), normals_(normal.data.size()),
        beliefs_(beliefs.size()), counts_(3) {
    keyframe_.uploadAsync(gray.data.data(), gray.data.size(), stream_.get());
    normals_.uploadAsync(normal.data.data(), normal.data.size(), stream_.get());
    beliefs_.uploadAsync(beliefs.data(), beliefs.size(), stream_.get());
    stream_.synchronize();  // the host vectors may go
  }

  DepthFilterUpdate update(const filter::FrameParams& params, const ImageU8& gray) override {
    const cuda::LayeredTexture8 frame({ImageViewU8(gray)});  // synchronous upload
    AMHMVS_CUDA_CHECK(cudaMemsetAsync(counts_.get(), 0, counts_.bytes(), stream_.get()));
    const mvs::GpuSampler keyframe{keyframe_.get(), width_, height_, frame.object()};
    const dim3 block(kBlockX, kBlockY);
    const dim3 grid((width_ + kBlockX - 1) / kBlockX, (height_ + kBlockY - 1) / kBlockY);
    filterKernel<<<grid, block, 0, stream_.get()>>>(keyframe, normals_.get(), beliefs_.get(), params, counts_.get());
    AMHMVS_CUDA_CHECK_LAUNCH();
    unsigned long long counts[3] = {0, 0, 0};
    counts_.downloadAsync(counts, 3, stream_.get());
    stream_.synchronize();  // before `frame`'s texture goes
    DepthFilterUpdate outcome;
    outcome.matched = counts[0];
    outcome.missed = counts[1];
    outcome.not_visible = counts[2];
    return outcome;
  }

  void download(std::vector<filter::DepthBelief>* beliefs) override {
    beliefs->resize(beliefs_.size());
    beliefs_.downloadAsync(beliefs->data(), beliefs_.size(), stream_.get());
    stream_.synchronize();
  }

 private:
  int width_, height_;
  cuda::CudaStream stream_;
  cuda::DeviceBuffer<uint8_t> keyframe_;
  cuda::DeviceBuffer<float> normals_;
  cuda::DeviceBuffer<filter::DepthBelief> beliefs_;
  cuda::DeviceBuffer<unsigned long long> counts_;
};

}  // namespace

std::unique_ptr<DeviceDepthFilter> makeCudaDepthFilter(const ImageU8& keyframe_gray, const ImageF& normal,
                                                       const std::vector<filter::DepthBelief>& beliefs) {
  return std::make_unique<CudaDepthFilter>(keyframe_gray, normal, beliefs);
}

}  // namespace amhmvs
