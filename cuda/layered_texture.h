// The source images of a depth map as one layered 8-bit texture with
// hardware bilinear filtering. One texture object, indexed by layer, avoids
// run-time indexing into an array of texture objects.
//
// Images smaller than the largest are padded by repeating their last row and
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

class LayeredTexture8 {
 public:
  explicit LayeredTexture8(const std::vector<const ImageU8*>& layers) {
    int width = 1, height = 1;
    for (const ImageU8* image : layers) {
      width = std::max(width, image->width);
      height = std::max(height, image->height);
    }
    const int count = static_cast<int>(layers.size());
    std::vector<uint8_t> staging(static_cast<size_t>(width) * height * count);
    for (int l = 0; l < count; ++l) {
      const ImageU8& image = *layers[l];
      uint8_t* layer = staging.data() + static_cast<size_t>(l) * width * height;
      for (int y = 0; y < height; ++y) {
        const uint8_t* source_row = &image.at(0, std::min(y, image.height - 1));
        uint8_t* row = layer + static_cast<size_t>(y) * width;
        std::copy(source_row, source_row + image.width, row);
        std::fill(row + image.width, row + width, source_row[image.width - 1]);
      }
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

    cudaResourceDesc resource = {};
    resource.resType = cudaResourceTypeArray;
    resource.res.array.array = array_;
    cudaTextureDesc texture = {};
    texture.addressMode[0] = cudaAddressModeClamp;
    texture.addressMode[1] = cudaAddressModeClamp;
    texture.filterMode = cudaFilterModeLinear;
    texture.readMode = cudaReadModeNormalizedFloat;  // 8-bit texels -> [0, 1]
    texture.normalizedCoords = 0;
    AMHMVS_CUDA_CHECK(cudaCreateTextureObject(&object_, &resource, &texture, nullptr));
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
