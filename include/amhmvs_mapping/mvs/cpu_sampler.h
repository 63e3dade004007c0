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
#include "amhmvs_mapping/mvs/cpu_lanes.h"
#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

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

// kCpuLanes source images, one per lane: textureBilinear lane by lane, with
// the same integer weights (computed exactly in float) and the same sums.
struct CpuSourceLanes {
  BytePairGather texels;
  FloatLanes max_x, max_y;

  FloatLanes sample(FloatLanes x, FloatLanes y) const {
    // As CpuSourceView::sample: NaN reads the low edge.
    x = clampLanes(x, -kCoordinateMargin, max_x);
    y = clampLanes(y, -kCoordinateMargin, max_y);
    const IntLanes qx = truncateToInt(x * 256.0f + (kFixedPointOffset + 0.5f)) - kFixedPointOffset;
    const IntLanes qy = truncateToInt(y * 256.0f + (kFixedPointOffset + 0.5f)) - kFixedPointOffset;
    const FloatLanes a = toFloat(qx & 255), b = toFloat(qy & 255);
    // Products below 2^17 and their quotients by 256 are exact in float; adding
    // and subtracting 1.5 * 2^23 rounds to an integer, half to even.
    auto weight = [](FloatLanes product) {
      const float kRound = 12582912.0f;
      return (product * (1.0f / 256.0f) + kRound) - kRound;
    };
    const FloatLanes w00 = weight((256.0f - a) * (256.0f - b)), w10 = weight(a * (256.0f - b));
    const FloatLanes w01 = weight((256.0f - a) * b), w11 = weight(a * b);
    IntLanes top{}, bottom{};  // texel pairs (x, x + 1) of rows y and y + 1, 8 bits each
    texels.gather(qx >> 8, qy >> 8, &top, &bottom);
    // Integer products and sums below 2^24: exact in float, as in textureBilinear.
    const FloatLanes sum = w00 * toFloat(top & 255) + w10 * toFloat(top >> 8) +
                           w01 * toFloat(bottom & 255) + w11 * toFloat(bottom >> 8);
    return sum * (1.0f / 256.0f);
  }
};

struct CpuSampler {
  // Matching costs are scored kCpuLanes at a time (see CostBatch).
  static constexpr int kLanes = kCpuLanes;

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

  // Costs of kCpuLanes (geometry, plane term) pairs in one pass over the
  // window: the scalar windowCost's arithmetic in each lane.
  template <class Window, class Samples>
  void laneCosts(const CostParams& p, const ReferenceWindowT<Samples>& win,
                 const SourceGeometry* const* geometry, const Vec3* q, int x, int y,
                 float* costs) const {
    WindowHomography<FloatLanes> H;
    CpuSourceLanes view;
    for (int l = 0; l < kCpuLanes; ++l) {
      const WindowHomography<float> h = windowHomography(*geometry[l], q[l]);
      for (int k = 0; k < 9; ++k) H.h[k][l] = h.h[k];
      H.width[l] = h.width;
      H.height[l] = h.height;
      const CpuSourceView source = sourceView(geometry[l]->layer);
      const PaddedImage8& image = *sources[geometry[l]->layer];
      view.texels.setLane(l, source.origin, source.stride, image.height + kPadding);
      view.max_x[l] = source.max_x;
      view.max_y[l] = source.max_y;
    }
    view.texels.finish();
    const FloatLanes c = windowCost<Window>(view, p, win, H, x, y);
    for (int l = 0; l < kCpuLanes; ++l) costs[l] = c[l];
  }
};

}  // namespace mvs
}  // namespace amhmvs
