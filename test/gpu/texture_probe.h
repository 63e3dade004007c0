// Samples a layered 8-bit texture on the GPU at given coordinates, to check
// that the CPU sampler reproduces the texture unit's bilinear filtering.
#pragma once

#include <vector>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Values (0..255 scale) of tex2DLayered at (x + 0.5, y + 0.5) in layer 0.
std::vector<float> sampleTextureOnGpu(const ImageU8& image, const std::vector<float>& xs,
                                      const std::vector<float>& ys);

// Peak bilinear fetch rate of the device (fetches per second) on an 8-bit
// layered texture with cache-resident coordinates: the floor the estimator's
// window loop is measured against. Median of `runs` timed launches (CUDA
// events) after a warm-up.
double measureBilinearFetchRate(int runs = 5);

}  // namespace amhmvs
