// Source images as one layered 8-bit texture with hardware bilinear
// filtering. One texture object, indexed by layer, avoids run-time indexing
// into an array of texture objects.
//
// Images smaller than the layers are padded by repeating their last row and
// column, which reproduces clamp-to-edge addressing for each image exactly.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "amhmvs_mapping/core/image.h"
#include "cuda_check.h"

namespace amhmvs {
namespace cuda {

// Writes `image` into a layer of width x height texels (at least the image's
// size), repeating its last column and row: clamp-to-edge for that image.
inline void padLayer(ImageViewU8 image, int width, int height, uint8_t* layer) {
  for (int y = 0; y < height; ++y) {
    const uint8_t* source_row = &image.at(0, std::min(y, image.height - 1));
    uint8_t* row = layer + static_cast<size_t>(y) * width;
    std::copy(source_row, source_row + image.width, row);
    std::fill(row + image.width, row + width, source_row[image.width - 1]);
  }
}

// Bilinear, clamped, unnormalised coordinates, 8-bit texels read as [0, 1]:
// what the estimator's kernels expect of the source images.
inline cudaTextureObject_t makeLayeredTexture(cudaArray_t array) {
  cudaResourceDesc resource = {};
  resource.resType = cudaResourceTypeArray;
  resource.res.array.array = array;
  cudaTextureDesc texture = {};
  texture.addressMode[0] = cudaAddressModeClamp;
  texture.addressMode[1] = cudaAddressModeClamp;
  texture.filterMode = cudaFilterModeLinear;
  texture.readMode = cudaReadModeNormalizedFloat;  // 8-bit texels -> [0, 1]
  texture.normalizedCoords = 0;
  cudaTextureObject_t object = 0;
  AMHMVS_CUDA_CHECK(cudaCreateTextureObject(&object, &resource, &texture, nullptr));
  return object;
}

// A fixed set of images as one layered texture (the texture probe of the GPU
// tests; the estimator keeps its images in a DeviceImagePool).
class LayeredTexture8 {
 public:
  explicit LayeredTexture8(const std::vector<ImageViewU8>& layers) {
    int width = 1, height = 1;
    for (const ImageViewU8& image : layers) {
      width = std::max(width, image.width);
      height = std::max(height, image.height);
    }
    const int count = static_cast<int>(layers.size());
    std::vector<uint8_t> staging(static_cast<size_t>(width) * height * count);
    for (int l = 0; l < count; ++l) {
      padLayer(layers[l], width, height, staging.data() + static_cast<size_t>(l) * width * height);
    }
    const cudaChannelFormatDesc format = cudaCreateChannelDesc<uint8_t>();
    AMHMVS_CUDA_CHECK(cudaMalloc3DArray(&array_, &format, make_cudaExtent(width, height, count),
                                        cudaArrayLayered));
    cudaMemcpy3DParms copy = {};
    copy.srcPtr = make_cudaPitchedPtr(staging.data(), width, width, height);
    copy.dstArray = array_;
    copy.extent = make_cudaExtent(width, height, count);
    copy.kind = cudaMemcpyHostToDevice;
    AMHMVS_CUDA_CHECK(cudaMemcpy3D(&copy));
    object_ = makeLayeredTexture(array_);
  }
  ~LayeredTexture8() {
    if (object_) cudaDestroyTextureObject(object_);
    if (array_) cudaFreeArray(array_);
  }
  LayeredTexture8(const LayeredTexture8&) = delete;
  LayeredTexture8& operator=(const LayeredTexture8&) = delete;

  cudaTextureObject_t object() const { return object_; }

 private:
  cudaArray_t array_ = nullptr;
  cudaTextureObject_t object_ = 0;
};

}  // namespace cuda
}  // namespace amhmvs
