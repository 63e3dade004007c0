// weakTextureMask (core/texture.h): the pixels whose neighbourhood has little
// grey-level gradient.
#include <gtest/gtest.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/texture.h"

namespace amhmvs {
namespace {

TEST(WeakTextureMask, FlatIsWeakAStepIsNotAndTheWindowReachesTwoPixels) {
  // Left half 100, right half 140: a step of 40 between columns 15 and 16.
  ImageU8 image(32, 8, 1);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 32; ++x) image.at(x, y) = x < 16 ? 100 : 140;
  const ImageU8 mask = weakTextureMask(image);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 32; ++x) {
      // The step's gradient (20 per pixel at columns 15 and 16) reaches the
      // 5x5 mean of columns 13..18: 40 / 5 = 8 > 3.
      const bool near_step = x >= 13 && x <= 18;
      EXPECT_EQ(mask.at(x, y), near_step ? 0 : 255) << x << "," << y;
    }
  }
  // A gentle ramp of 2 grey levels per pixel stays weak; 4 does not.
  for (int slope : {2, 4}) {
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 32; ++x) image.at(x, y) = static_cast<uint8_t>(50 + slope * x);
    EXPECT_EQ(weakTextureMask(image).at(10, 4), slope < kWeakTextureGradient ? 255 : 0) << slope;
  }
}

TEST(WeakTextureMask, RefusesColour) {
  const ImageU8 colour(4, 4, 3);
  EXPECT_THROW(weakTextureMask(colour), InputError);
}

}  // namespace
}  // namespace amhmvs
