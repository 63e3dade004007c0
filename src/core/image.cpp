#include "amhmvs_mapping/core/image.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

ImageU8 toGray(const ImageU8& image) {
  if (image.channels == 1) return image;
  // RGBA is accepted too: alpha carries no luma.
  if (image.channels != 3 && image.channels != 4) {
    throw InputError("toGray: expected a 1-, 3- or 4-channel image, got " +
                     std::to_string(image.channels) + " channels");
  }
  ImageU8 gray(image.width, image.height, 1);
  const size_t n = image.pixelCount();
  const int c = image.channels;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* p = &image.data[i * c];
    // Integer BT.601 weights (x1000) so the result is exact and reproducible.
    const unsigned sum = 299u * p[0] + 587u * p[1] + 114u * p[2];
    gray.data[i] = static_cast<uint8_t>((sum + 500u) / 1000u);
  }
  return gray;
}

namespace {

// Source pixels that one destination pixel covers along one axis, with the
// covered length of each (in source pixels).
struct Span {
  int first = 0;
  std::vector<double> weights;
};

// Destination pixel i covers the source interval [i * scale, (i + 1) * scale)
// (pixel edges, scale = src / dst), which is the "about pixel centres" mapping.
std::vector<Span> coverage(int src, int dst) {
  std::vector<Span> spans(dst);
  const double scale = static_cast<double>(src) / dst;
  for (int i = 0; i < dst; ++i) {
    const double lo = i * scale;
    const double hi = (i + 1) * scale;
    int first = static_cast<int>(std::floor(lo));
    int last = static_cast<int>(std::ceil(hi)) - 1;
    first = std::max(0, std::min(first, src - 1));
    last = std::max(first, std::min(last, src - 1));
    Span& span = spans[i];
    span.first = first;
    for (int s = first; s <= last; ++s) {
      const double w = std::min(hi, s + 1.0) - std::max(lo, static_cast<double>(s));
      span.weights.push_back(std::max(0.0, w));
    }
  }
  return spans;
}

// resizeArea for whole box factors (e.g. the halving of coarse-to-fine
// scales): integer sums, rounded half up as the general path rounds them
// (its weights are then exactly 1), so the bytes are the same, ~50x faster.
ImageU8 resizeByIntegerFactor(const ImageViewU8& image, int width, int height) {
  const int c = image.channels, fx = image.width / width, fy = image.height / height;
  const uint32_t area = static_cast<uint32_t>(fx) * fy;
  ImageU8 out(width, height, c);
  std::vector<uint32_t> sums(static_cast<size_t>(width) * c);
  for (int y = 0; y < height; ++y) {
    std::fill(sums.begin(), sums.end(), 0u);
    for (int sy = y * fy; sy < (y + 1) * fy; ++sy) {
      const uint8_t* row = &image.data[image.index(0, sy)];
      for (int x = 0; x < width; ++x) {
        for (int k = 0; k < fx * c; ++k) sums[static_cast<size_t>(x) * c + k % c] += row[(x * fx) * c + k];
      }
    }
    uint8_t* out_row = &out.data[out.index(0, y)];
    for (size_t i = 0; i < sums.size(); ++i) out_row[i] = static_cast<uint8_t>((2 * sums[i] + area) / (2 * area));
  }
  return out;
}

}  // namespace

ImageU8 resizeArea(const ImageViewU8& image, int width, int height) {
  if (width <= 0 || height <= 0) {
    throw InputError("resizeArea: target size must be positive, got " + std::to_string(width) +
                     "x" + std::to_string(height));
  }
  if (image.empty()) throw InputError("resizeArea: input image is empty");
  if (image.sameSize(width, height)) {
    ImageU8 copy(width, height, image.channels);
    std::copy(image.data, image.data + copy.data.size(), copy.data.begin());
    return copy;
  }

  const int c = image.channels;
  if (image.width % width == 0 && image.height % height == 0) return resizeByIntegerFactor(image, width, height);
  const std::vector<Span> xs = coverage(image.width, width);
  const std::vector<Span> ys = coverage(image.height, height);

  // Separable: horizontal sums per source row, then vertical sums. Doubles keep
  // the sums exact for integer box factors (weights are then 1.0).
  std::vector<double> rows(static_cast<size_t>(width) * image.height * c, 0.0);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Span& span = xs[x];
      double* out = &rows[(static_cast<size_t>(y) * width + x) * c];
      for (size_t k = 0; k < span.weights.size(); ++k) {
        const uint8_t* in = &image.data[image.index(span.first + static_cast<int>(k), y)];
        for (int ch = 0; ch < c; ++ch) out[ch] += span.weights[k] * in[ch];
      }
    }
  }

  const double area = (static_cast<double>(image.width) / width) *
                      (static_cast<double>(image.height) / height);
  ImageU8 out(width, height, c);
  std::vector<double> acc(c);
  for (int y = 0; y < height; ++y) {
    const Span& span = ys[y];
    for (int x = 0; x < width; ++x) {
      std::fill(acc.begin(), acc.end(), 0.0);
      for (size_t k = 0; k < span.weights.size(); ++k) {
        const double* in =
            &rows[((span.first + static_cast<size_t>(k)) * width + x) * c];
        for (int ch = 0; ch < c; ++ch) acc[ch] += span.weights[k] * in[ch];
      }
      for (int ch = 0; ch < c; ++ch) {
        // Round half up; the epsilon absorbs rounding error of fractional weights.
        const double v = std::floor(acc[ch] / area + 0.5 + 1e-9);
        out.at(x, y, ch) = static_cast<uint8_t>(std::max(0.0, std::min(255.0, v)));
      }
    }
  }
  return out;
}

}  // namespace amhmvs
