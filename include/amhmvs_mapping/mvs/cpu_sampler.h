// CPU image sampler that reproduces CUDA texture fetches.
//
// The CUDA backend reads 8-bit textures with hardware bilinear filtering,
// which computes the interpolation weights in 9-bit fixed point (8 fractional
// bits). This sampler does the same arithmetic so that both backends score a
// hypothesis alike up to float rounding.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

// Coordinates are clamped to [-kCoordinateMargin, size + kCoordinateMargin]
// before sampling; images are padded by kPadding replicated pixels, which
// reproduces clamp-to-edge addressing without a test per sample. The offset
// keeps the fixed-point value positive so that truncation is floor.
constexpr float kCoordinateMargin = 2.0f;
constexpr int kPadding = 4;
constexpr int kFixedPointOffset = 1024;  // > 256 * kCoordinateMargin

// An 8-bit image with kPadding replicated pixels on every side.
struct PaddedImage8 {
  std::vector<uint8_t> storage;
  int width = 0, height = 0, stride = 0;
  const uint8_t* origin = nullptr;  // pixel (0, 0)

  explicit PaddedImage8(ImageViewU8 image)
      : storage(static_cast<size_t>(image.width + 2 * kPadding) * (image.height + 2 * kPadding)),
        width(image.width), height(image.height), stride(image.width + 2 * kPadding) {
    for (int y = -kPadding; y < height + kPadding; ++y) {
      const int clamped_y = y < 0 ? 0 : (y >= height ? height - 1 : y);
      for (int x = -kPadding; x < width + kPadding; ++x) {
        const int clamped_x = x < 0 ? 0 : (x >= width ? width - 1 : x);
        storage[static_cast<size_t>(y + kPadding) * stride + x + kPadding] =
            image.at(clamped_x, clamped_y);
      }
    }
    origin = storage.data() + static_cast<size_t>(kPadding) * stride + kPadding;
  }
  PaddedImage8(const PaddedImage8&) = delete;
  PaddedImage8& operator=(const PaddedImage8&) = delete;
};

// Bilinear sample at (x, y) in pixel-centre coordinates, as the texture unit
// computes it (measured on an H100 by test/gpu/gpu_tests.cpp): the
// coordinates are rounded to 1/256 pixel, whose integer parts pick the texels
// and whose fractions a, b (in 1/256) give the four weights (1-a)(1-b),
// a(1-b), (1-a)b, ab, each rounded half-to-even to 1/256. All in integers.
// (x, y) must lie within kCoordinateMargin of the image.
inline float textureBilinear(const uint8_t* origin, int stride, float x, float y) {
  const int qx = static_cast<int>(x * 256.0f + (kFixedPointOffset + 0.5f)) - kFixedPointOffset;
  const int qy = static_cast<int>(y * 256.0f + (kFixedPointOffset + 0.5f)) - kFixedPointOffset;
  const int ix = qx >> 8, iy = qy >> 8;  // arithmetic shift: floor division
  const int a = qx & 255, b = qy & 255;
  auto weight = [](int product) {  // product / 256, rounded half to even
    return (product + 127 + ((product >> 8) & 1)) >> 8;
  };
  const int w00 = weight((256 - a) * (256 - b)), w10 = weight(a * (256 - b));
  const int w01 = weight((256 - a) * b), w11 = weight(a * b);
  const uint8_t* p = origin + static_cast<ptrdiff_t>(iy) * stride + ix;
  const int sum = w00 * p[0] + w10 * p[1] + w01 * p[stride] + w11 * p[stride + 1];
  return static_cast<float>(sum) * (1.0f / 256.0f);
}

inline float textureBilinear(const PaddedImage8& image, float x, float y) {
  const float lo = -kCoordinateMargin;
  const float max_x = image.width + kCoordinateMargin, max_y = image.height + kCoordinateMargin;
  x = x > lo ? (x < max_x ? x : max_x) : lo;
  y = y > lo ? (y < max_y ? y : max_y) : lo;
  return textureBilinear(image.origin, image.stride, x, y);
}

// One source image; hoisted out of the sample loop by matchingCost.
struct CpuSourceView {
  const uint8_t* origin;
  int stride;
  float max_x, max_y;

  float sample(float x, float y) const {
    // Far-off coordinates read the edge anyway; the comparisons also map NaN
    // (a degenerate homography) to the edge.
    const float lo = -kCoordinateMargin;
    x = x > lo ? (x < max_x ? x : max_x) : lo;
    y = y > lo ? (y < max_y ? y : max_y) : lo;
    return textureBilinear(origin, stride, x, y);
  }
};

struct CpuSampler {
  ImageViewU8 reference_image;
  const PaddedImage8* sources[32];

  // Intensity at an integer pixel, -1 outside the image.
  float reference(int x, int y) const {
    const bool inside = x >= 0 && y >= 0 && x < reference_image.width && y < reference_image.height;
    return inside ? static_cast<float>(reference_image.data[static_cast<size_t>(y) * reference_image.width + x])
                  : -1.0f;
  }
  CpuSourceView sourceView(int view) const {
    const PaddedImage8& image = *sources[view];
    return {image.origin, image.stride, image.width + kCoordinateMargin,
            image.height + kCoordinateMargin};
  }
};

}  // namespace mvs
}  // namespace amhmvs
