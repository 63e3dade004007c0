#include "amhmvs_mapping/core/texture.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

ImageU8 weakTextureMask(const ImageViewU8& grey, float max_gradient, int radius) {
  if (grey.channels != 1) throw InputError("weak texture mask: the image must be grey (1 channel)");
  const int w = grey.width, h = grey.height;
  // Gradient magnitude, then its box sum through an integral image.
  std::vector<double> integral(static_cast<size_t>(w + 1) * (h + 1), 0.0);
  for (int y = 0; y < h; ++y) {
    double row = 0;
    for (int x = 0; x < w; ++x) {
      const int xl = std::max(x - 1, 0), xr = std::min(x + 1, w - 1);
      const int yu = std::max(y - 1, 0), yd = std::min(y + 1, h - 1);
      row += 0.5 * (std::abs(grey.at(xr, y) - grey.at(xl, y)) + std::abs(grey.at(x, yd) - grey.at(x, yu)));
      integral[static_cast<size_t>(y + 1) * (w + 1) + x + 1] = integral[static_cast<size_t>(y) * (w + 1) + x + 1] + row;
    }
  }
  ImageU8 mask(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int x0 = std::max(x - radius, 0), x1 = std::min(x + radius, w - 1) + 1;
      const int y0 = std::max(y - radius, 0), y1 = std::min(y + radius, h - 1) + 1;
      const auto at = [&](int xx, int yy) { return integral[static_cast<size_t>(yy) * (w + 1) + xx]; };
      const double sum = at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
      mask.at(x, y) = sum / ((x1 - x0) * (y1 - y0)) < max_gradient ? 255 : 0;
    }
  }
  return mask;
}

}  // namespace amhmvs
