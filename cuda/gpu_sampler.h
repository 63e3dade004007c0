// The images as the per-pixel code reads them on the GPU (matching_cost.h's
// Sampler and SourceView): the reference from global memory (exact integer
// reads), the sources from a layered texture (hardware bilinear filtering,
// which cpu_sampler.h reproduces on the CPU).
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

namespace amhmvs {
namespace mvs {

// One source view: a layer of the layered texture.
struct GpuSourceView {
  cudaTextureObject_t texture;
  int layer;

  __device__ float sample(float x, float y) const {
    // Texture coordinates put pixel centres at +0.5.
    return tex2DLayered<float>(texture, x + 0.5f, y + 0.5f, layer) * 255.0f;
  }
};

struct GpuSampler {
  static constexpr int kLanes = 1;  // matching costs one at a time (CostBatch)

  const uint8_t* reference_pixels;
  int width, height;
  cudaTextureObject_t sources;

  // Intensity at an integer pixel, -1 outside the image.
  __device__ float reference(int x, int y) const {
    if (x < 0 || y < 0 || x >= width || y >= height) return -1.0f;
    return static_cast<float>(__ldg(reference_pixels + y * width + x));
  }
  __device__ GpuSourceView sourceView(int view) const { return {sources, view}; }
};

}  // namespace mvs
}  // namespace amhmvs
