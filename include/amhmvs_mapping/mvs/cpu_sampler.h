// CPU image sampler that reproduces CUDA texture fetches.
//
// The CUDA backend reads 8-bit textures with hardware bilinear filtering,
// which computes the interpolation weights in 9-bit fixed point (8 fractional
// bits). This sampler does the same arithmetic so that both backends score a
// hypothesis alike up to float rounding.
#pragma once

#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

struct HostImage8 {
  const uint8_t* pixels;
  int width, height;

  float at(int x, int y) const {
    x = x < 0 ? 0 : (x >= width ? width - 1 : x);
    y = y < 0 ? 0 : (y >= height ? height - 1 : y);
    return pixels[static_cast<size_t>(y) * width + x];
  }
};

// Bilinear sample at (x, y) in pixel-centre coordinates with clamp-to-edge,
// weights quantised to 1/256 as the texture unit does.
inline float textureBilinear(const HostImage8& image, float x, float y) {
  const float fx = floorf(x), fy = floorf(y);
  const float a = std::nearbyint((x - fx) * 256.0f) * (1.0f / 256.0f);
  const float b = std::nearbyint((y - fy) * 256.0f) * (1.0f / 256.0f);
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  const float t00 = image.at(ix, iy) * (1.0f / 255.0f), t10 = image.at(ix + 1, iy) * (1.0f / 255.0f);
  const float t01 = image.at(ix, iy + 1) * (1.0f / 255.0f),
              t11 = image.at(ix + 1, iy + 1) * (1.0f / 255.0f);
  const float value = (1.0f - a) * (1.0f - b) * t00 + a * (1.0f - b) * t10 +
                      (1.0f - a) * b * t01 + a * b * t11;
  return value * 255.0f;
}

struct CpuSampler {
  HostImage8 reference_image;
  HostImage8 sources[32];

  float reference(int x, int y) const { return reference_image.at(x, y); }
  float source(int view, float x, float y) const {
    if (!(x == x) || !(y == y)) return 0.0f;  // NaN coordinates (degenerate homography)
    // Keep far-off coordinates inside int range; clamping makes them edge reads anyway.
    x = fminf(fmaxf(x, -2.0f), sources[view].width + 1.0f);
    y = fminf(fmaxf(y, -2.0f), sources[view].height + 1.0f);
    return textureBilinear(sources[view], x, y);
  }
};

}  // namespace mvs
}  // namespace amhmvs
