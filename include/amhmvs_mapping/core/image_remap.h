// Resampling an image through a per-pixel map: output pixel (u, v) takes the
// input bilinearly at the position the map gives (lens undistortion, rolling
// shutter rectification).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// What an output pixel whose position falls outside the input gets.
enum class RemapBorder {
  kZero,   // 0
  kClamp,  // the nearest input pixel (positions clamped to the image)
};

// `position(u, v, &su, &sv)` gives the input position of output pixel
// (u, v), pixel centres at integers. The output has the input's size.
template <class InputPosition>
ImageU8 remapBilinear(const ImageU8& image, InputPosition position, RemapBorder border) {
  ImageU8 out(image.width, image.height, image.channels, 0);
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      double su = 0, sv = 0;
      position(u, v, &su, &sv);
      if (border == RemapBorder::kClamp) {
        su = std::min(std::max(su, 0.0), image.width - 1.0);
        sv = std::min(std::max(sv, 0.0), image.height - 1.0);
      }
      int u0 = static_cast<int>(std::floor(su)), v0 = static_cast<int>(std::floor(sv));
      if (border == RemapBorder::kClamp) {
        // The last row or column: step back so that u0 + 1 / v0 + 1 exist (weight 1 on the edge).
        u0 = std::min(u0, std::max(image.width - 2, 0));
        v0 = std::min(v0, std::max(image.height - 2, 0));
      }
      if (u0 < 0 || v0 < 0 || u0 + 1 >= image.width || v0 + 1 >= image.height) continue;
      const double a = su - u0, b = sv - v0;
      for (int c = 0; c < image.channels; ++c) {
        const double value = (1 - a) * (1 - b) * image.at(u0, v0, c) + a * (1 - b) * image.at(u0 + 1, v0, c) +
                             (1 - a) * b * image.at(u0, v0 + 1, c) + a * b * image.at(u0 + 1, v0 + 1, c);
        out.at(u, v, c) = static_cast<uint8_t>(std::lround(value));
      }
    }
  }
  return out;
}

}  // namespace amhmvs
