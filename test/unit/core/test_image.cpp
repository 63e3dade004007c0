// toGray and resizeArea (core/image.h).
#include "amhmvs_mapping/core/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

using test::randomImage;

TEST(ToGray, Bt601WeightsRounded) {
  ImageU8 rgb(5, 1, 3);
  const uint8_t pixels[5][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255},
                                {10, 20, 30}};
  for (int x = 0; x < 5; ++x) {
    for (int c = 0; c < 3; ++c) rgb.at(x, 0, c) = pixels[x][c];
  }
  const ImageU8 gray = toGray(rgb);
  ASSERT_EQ(gray.channels, 1);
  ASSERT_EQ(gray.width, 5);
  // 0.299*255 = 76.2, 0.587*255 = 149.7, 0.114*255 = 29.1, 2.99+11.74+3.42 = 18.15
  EXPECT_EQ(gray.at(0, 0), 76);
  EXPECT_EQ(gray.at(1, 0), 150);
  EXPECT_EQ(gray.at(2, 0), 29);
  EXPECT_EQ(gray.at(3, 0), 255);
  EXPECT_EQ(gray.at(4, 0), 18);
}

TEST(ToGray, GrayUnchangedAndBadChannelsRejected) {
  const ImageU8 gray = randomImage(7, 3, 1, 1);
  EXPECT_EQ(toGray(gray).data, gray.data);
  EXPECT_THROW(toGray(ImageU8(2, 2, 2)), InputError);
}

TEST(ResizeArea, IntegerFactorIsBoxMeanRoundedToNearest) {
  const ImageU8 in = randomImage(24, 16, 3, 2);
  const ImageU8 out = resizeArea(in, 6, 4);
  ASSERT_EQ(out.width, 6);
  ASSERT_EQ(out.height, 4);
  ASSERT_EQ(out.channels, 3);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) {
      for (int c = 0; c < 3; ++c) {
        int sum = 0;
        for (int dy = 0; dy < 4; ++dy) {
          for (int dx = 0; dx < 4; ++dx) sum += in.at(4 * x + dx, 4 * y + dy, c);
        }
        ASSERT_EQ(out.at(x, y, c), (sum + 8) / 16) << x << "," << y << "," << c;
      }
    }
  }
}

// Whole box factors of any shape and channel count (the halving of
// coarse-to-fine scales among them): the box mean, rounded half up.
TEST(ResizeArea, AnyWholeFactorIsBoxMeanRoundedHalfUp) {
  struct Case {
    int width, height, channels, fx, fy;
  };
  for (const Case& k : {Case{640, 480, 1, 2, 2}, Case{30, 14, 1, 3, 2}, Case{21, 12, 3, 1, 3}, Case{10, 10, 2, 5, 1}}) {
    const ImageU8 in = randomImage(k.width, k.height, k.channels, 7);
    const ImageU8 out = resizeArea(in, k.width / k.fx, k.height / k.fy);
    const int area = k.fx * k.fy;
    for (int y = 0; y < out.height; ++y) {
      for (int x = 0; x < out.width; ++x) {
        for (int c = 0; c < k.channels; ++c) {
          int sum = 0;
          for (int dy = 0; dy < k.fy; ++dy) {
            for (int dx = 0; dx < k.fx; ++dx) sum += in.at(k.fx * x + dx, k.fy * y + dy, c);
          }
          ASSERT_EQ(out.at(x, y, c), (2 * sum + area) / (2 * area))
              << k.width << "x" << k.height << " by " << k.fx << "x" << k.fy << " at " << x << "," << y << "," << c;
        }
      }
    }
  }
}

TEST(ResizeArea, HalvesRoundUp) {
  ImageU8 in(2, 2, 1);
  in.data = {0, 1, 0, 1};  // mean 0.5 -> 1
  EXPECT_EQ(resizeArea(in, 1, 1).data[0], 1);
  in.data = {0, 1, 1, 1};  // mean 0.75 -> 1
  EXPECT_EQ(resizeArea(in, 1, 1).data[0], 1);
  in.data = {0, 0, 0, 1};  // mean 0.25 -> 0
  EXPECT_EQ(resizeArea(in, 1, 1).data[0], 0);
}

TEST(ResizeArea, FractionalCoverage) {
  // 3 -> 2: each output pixel covers 1.5 source pixels.
  ImageU8 in(3, 1, 1);
  in.data = {0, 30, 90};
  const ImageU8 out = resizeArea(in, 2, 1);
  EXPECT_EQ(out.data[0], 10);  // (0 + 0.5*30) / 1.5
  EXPECT_EQ(out.data[1], 70);  // (0.5*30 + 90) / 1.5
  // Upscaling 2 -> 4 replicates (each output covers half a source pixel).
  ImageU8 small(2, 1, 1);
  small.data = {10, 50};
  EXPECT_EQ(resizeArea(small, 4, 1).data, (std::vector<uint8_t>{10, 10, 50, 50}));
}

TEST(ResizeArea, ConstantImageStaysConstant) {
  const ImageU8 in(7, 5, 3, 77);
  for (auto size : {std::make_pair(3, 2), std::make_pair(5, 4), std::make_pair(11, 9)}) {
    const ImageU8 out = resizeArea(in, size.first, size.second);
    for (uint8_t v : out.data) ASSERT_EQ(v, 77);
  }
}

TEST(ResizeArea, SameSizeAndInvalidSizes) {
  const ImageU8 in = randomImage(5, 4, 1, 3);
  EXPECT_EQ(resizeArea(in, 5, 4).data, in.data);
  EXPECT_THROW(resizeArea(in, 0, 4), InputError);
  EXPECT_THROW(resizeArea(ImageU8(), 2, 2), InputError);
}

// The x0.25 fountain folder was area-downsampled from the full-size JPEGs, so
// our resize of a full image must reproduce it (up to JPEG decoder differences).
TEST(ResizeArea, ReproducesRealQuarterResolutionFountain) {
  if (!canDecodeCompressedImages()) GTEST_SKIP() << "built without OpenCV (no JPEG decoder)";
  AMHMVS_REQUIRE_DATA(full_path, "strecha/fountain-P11/images/0000.jpg");
  AMHMVS_REQUIRE_DATA(quarter_path, "mvsnet/fountain_x0.25/images/00000000.png");
  const ImageU8 full = readImage(full_path);
  const ImageU8 quarter = readImage(quarter_path);
  ASSERT_EQ(full.width, 3072);
  ASSERT_EQ(quarter.width, 768);
  const ImageU8 ours = resizeArea(full, 768, 512);
  ASSERT_EQ(ours.data.size(), quarter.data.size());
  int max_diff = 0;
  double sum_diff = 0;
  for (size_t i = 0; i < ours.data.size(); ++i) {
    const int d = std::abs(int(ours.data[i]) - int(quarter.data[i]));
    max_diff = std::max(max_diff, d);
    sum_diff += d;
  }
  RecordProperty("max_diff", max_diff);
  EXPECT_LE(sum_diff / static_cast<double>(ours.data.size()), 0.05);
  EXPECT_LE(max_diff, 1);
}

}  // namespace
}  // namespace amhmvs
