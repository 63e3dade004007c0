#include "amhmvs_mapping/io/colormap.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

namespace {

// Viridis sampled at 0, 0.1, ..., 1 (the published 11-step palette); linear
// interpolation between these stays within a couple of levels of the full map.
const unsigned char kViridis[11][3] = {
    {0x44, 0x01, 0x54}, {0x48, 0x24, 0x75}, {0x41, 0x44, 0x87}, {0x35, 0x5f, 0x8d},
    {0x2a, 0x78, 0x8e}, {0x21, 0x91, 0x8c}, {0x22, 0xa8, 0x84}, {0x44, 0xbf, 0x70},
    {0x7a, 0xd1, 0x51}, {0xbd, 0xdf, 0x26}, {0xfd, 0xe7, 0x25}};

void viridis(double t, uint8_t* rgb) {
  t = std::max(0.0, std::min(1.0, t)) * 10.0;
  const int i = std::min(9, static_cast<int>(t));
  const double f = t - i;
  for (int c = 0; c < 3; ++c) {
    const double v = kViridis[i][c] + f * (kViridis[i + 1][c] - kViridis[i][c]);
    rgb[c] = static_cast<uint8_t>(std::lround(v));
  }
}

}  // namespace

ImageU8 colorizeDepth(const ImageF& depth, float min, float max) {
  if (depth.channels != 1) {
    throw InputError("colorizeDepth: expected a 1-channel image, got " +
                     std::to_string(depth.channels) + " channels");
  }
  if (!std::isfinite(min) || !std::isfinite(max) || min > max) {
    throw InputError("colorizeDepth: invalid range [" + std::to_string(min) + ", " +
                     std::to_string(max) + "] (must be finite with min <= max)");
  }
  ImageU8 rgb(depth.width, depth.height, 3, 0);
  const double span = static_cast<double>(max) - min;
  for (size_t i = 0; i < depth.data.size(); ++i) {
    const float v = depth.data[i];
    if (!std::isfinite(v)) continue;  // stays black
    const double t = span > 0 ? (v - static_cast<double>(min)) / span : 0.5;
    viridis(t, &rgb.data[3 * i]);
  }
  return rgb;
}

std::pair<float, float> robustRange(const ImageF& image, double low_pct, double high_pct) {
  if (!(low_pct >= 0 && low_pct <= high_pct && high_pct <= 1)) {
    throw InputError("robustRange: percentiles must satisfy 0 <= low <= high <= 1 (got " +
                     std::to_string(low_pct) + ", " + std::to_string(high_pct) + ")");
  }
  std::vector<float> values;
  values.reserve(image.data.size());
  for (float v : image.data) {
    if (std::isfinite(v)) values.push_back(v);
  }
  if (values.empty()) throw InputError("robustRange: image has no finite values");
  // Two order statistics per quantile by selection (linear time), the same
  // values a full sort would put at those positions.
  auto quantile = [&](double p) {
    const double pos = p * static_cast<double>(values.size() - 1);
    const size_t lo = static_cast<size_t>(std::floor(pos));
    const size_t hi = std::min(values.size() - 1, lo + 1);
    const double f = pos - static_cast<double>(lo);
    std::nth_element(values.begin(), values.begin() + lo, values.end());
    const float at_lo = values[lo];
    // After the selection everything past lo is >= values[lo]: its minimum is the next order statistic.
    const float at_hi = hi == lo ? at_lo : *std::min_element(values.begin() + hi, values.end());
    return static_cast<float>(at_lo + f * (static_cast<double>(at_hi) - at_lo));
  };
  return {quantile(low_pct), quantile(high_pct)};
}

}  // namespace amhmvs
