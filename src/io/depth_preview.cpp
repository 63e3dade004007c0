#include "amhmvs_mapping/io/depth_preview.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/colormap.h"

namespace amhmvs {
namespace {

// 3x5 pixel glyphs (rows top to bottom, 3 bits each, MSB left) of the
// characters a label needs: digits, '.', 'm', ' '.
const unsigned char kDigitGlyphs[10][5] = {
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
const unsigned char kDotGlyph[5] = {0, 0, 0, 0, 2};
const unsigned char kMetreGlyph[5] = {0, 0, 7, 7, 5};
constexpr int kGlyphScale = 2;  // pixels per glyph pixel
constexpr int kBarHeight = 8, kBarMargin = 2;

const unsigned char* glyph(char c) {
  if (c >= '0' && c <= '9') return kDigitGlyphs[c - '0'];
  if (c == '.') return kDotGlyph;
  if (c == 'm') return kMetreGlyph;
  return nullptr;  // a space
}

// Width in pixels of `text` as drawText draws it.
int textWidth(const std::string& text) { return static_cast<int>(text.size()) * 4 * kGlyphScale; }

void drawText(const std::string& text, int left, int top, ImageU8* image) {
  for (size_t i = 0; i < text.size(); ++i) {
    const unsigned char* rows = glyph(text[i]);
    if (rows == nullptr) continue;
    for (int gy = 0; gy < 5 * kGlyphScale; ++gy) {
      for (int gx = 0; gx < 3 * kGlyphScale; ++gx) {
        if (!((rows[gy / kGlyphScale] >> (2 - gx / kGlyphScale)) & 1)) continue;
        const int x = left + static_cast<int>(i) * 4 * kGlyphScale + gx, y = top + gy;
        if (x < 0 || y < 0 || x >= image->width || y >= image->height) continue;
        for (int c = 0; c < 3; ++c) image->at(x, y, c) = 255;
      }
    }
  }
}

std::string metres(float value) {
  char text[32];
  std::snprintf(text, sizeof text, value < 10 ? "%.2fm" : "%.1fm", value);
  return text;
}

}  // namespace

ImageU8 depthPreview(const ImageF& depth, float fallback_min, float fallback_max) {
  std::pair<float, float> range(fallback_min, fallback_max);
  try {
    range = robustRange(depth);
  } catch (const InputError&) {  // no finite depth: the fallback range
  }
  const ImageU8 colours = colorizeDepth(depth, range.first, range.second);
  ImageU8 preview(depth.width, depth.height + kScaleBarRows, 3, 0);
  std::copy(colours.data.begin(), colours.data.end(), preview.data.begin());
  // The bar: near (left) to far (right), as the colours of the image.
  ImageF ramp(depth.width, 1, 1);
  for (int x = 0; x < depth.width; ++x)
    ramp.at(x, 0) = range.first + (range.second - range.first) * x / std::max(1, depth.width - 1);
  const ImageU8 bar = colorizeDepth(ramp, range.first, range.second);
  for (int y = depth.height + kBarMargin; y < depth.height + kBarMargin + kBarHeight; ++y)
    for (int x = 0; x < depth.width; ++x)
      for (int c = 0; c < 3; ++c) preview.at(x, y, c) = bar.at(x, 0, c);
  const int label_top = depth.height + kBarMargin + kBarHeight + 1;
  const std::string near = metres(range.first), far = metres(range.second);
  drawText(near, 1, label_top, &preview);
  drawText(far, depth.width - textWidth(far), label_top, &preview);
  return preview;
}

}  // namespace amhmvs
