// The depth preview every tool writes (depth_preview.h): the viridis image
// over the robust range, then a scale bar from near to far with labels.
#include "amhmvs_mapping/io/depth_preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "amhmvs_mapping/io/colormap.h"

namespace amhmvs {
namespace {

int whitePixels(const ImageU8& image, int top, int bottom) {
  int count = 0;
  for (int y = top; y < bottom; ++y)
    for (int x = 0; x < image.width; ++x)
      count += image.at(x, y, 0) == 255 && image.at(x, y, 1) == 255 && image.at(x, y, 2) == 255;
  return count;
}

TEST(DepthPreview, ImageThenScaleBarFromNearToFarWithLabels) {
  ImageF depth(100, 40, 1);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) depth.at(x, y) = 2.0f + 3.0f * x / (depth.width - 1);
  depth.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
  const ImageU8 preview = depthPreview(depth, 0.1f, 100.0f);
  ASSERT_EQ(preview.width, 100);
  ASSERT_EQ(preview.height, 40 + kScaleBarRows);
  const std::pair<float, float> range = robustRange(depth);
  const ImageU8 expected = colorizeDepth(depth, range.first, range.second);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(preview.at(x, y, c), expected.at(x, y, c));
  EXPECT_EQ(preview.at(0, 0, 0) + preview.at(0, 0, 1) + preview.at(0, 0, 2), 0) << "NaN is black";
  // The bar's ends have the colours of the range's ends.
  ImageF ends(2, 1, 1);
  ends.at(0, 0) = range.first;
  ends.at(1, 0) = range.second;
  const ImageU8 end_colours = colorizeDepth(ends, range.first, range.second);
  const int bar_row = depth.height + 5;
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(preview.at(0, bar_row, c), end_colours.at(0, 0, c));
    EXPECT_EQ(preview.at(99, bar_row, c), end_colours.at(1, 0, c));
  }
  EXPECT_GT(whitePixels(preview, depth.height, preview.height), 50) << "the near and far labels";
  EXPECT_EQ(whitePixels(preview, 0, depth.height), 0);
}

TEST(DepthPreview, WithoutFiniteDepthTheFallbackRangeLabelsTheBar) {
  const ImageF none(60, 10, 1, std::numeric_limits<float>::quiet_NaN());
  const ImageU8 preview = depthPreview(none, 1.0f, 5.0f);
  EXPECT_EQ(whitePixels(preview, 0, none.height), 0);
  EXPECT_GT(whitePixels(preview, none.height, preview.height), 30);
}

}  // namespace
}  // namespace amhmvs
