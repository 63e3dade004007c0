// Counter-based per-pixel random numbers (random.h): determinism, independence
// of pixels, streams and seeds, and the range and mean of uniform().
#include "amhmvs_mapping/mvs/random.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <vector>

namespace amhmvs {
namespace mvs {
namespace {

std::vector<float> draws(uint32_t seed, uint32_t pixel, uint32_t stream, int n) {
  PixelRandom rng(seed, pixel, stream);
  std::vector<float> out(n);
  for (float& v : out) v = rng.uniform();
  return out;
}

// Number of values two sequences share (24-bit values: chance matches are rare).
int common(const std::vector<float>& a, const std::vector<float>& b) {
  const std::set<float> sa(a.begin(), a.end());
  int n = 0;
  for (float v : b) n += static_cast<int>(sa.count(v));
  return n;
}

TEST(PixelRandom, SameSeedPixelAndStreamRepeatExactly) {
  const std::vector<float> a = draws(42, 1234, 3, 1000);
  const std::vector<float> b = draws(42, 1234, 3, 1000);
  EXPECT_EQ(a, b);
  // Not a constant sequence.
  EXPECT_GT(std::set<float>(a.begin(), a.end()).size(), 990u);
}

TEST(PixelRandom, PinnedValuesAreStableAcrossBuilds) {
  // A pure function of its inputs: recorded runs (and the other backend) must
  // redraw the same numbers. Values as 24-bit integers, u * 2^24.
  PixelRandom rng(0, 0, 0);
  EXPECT_EQ(rng.uniform() * 16777216.0f, 14819496.0f);
  EXPECT_EQ(rng.uniform() * 16777216.0f, 2953000.0f);
  EXPECT_EQ(rng.uniform() * 16777216.0f, 3955558.0f);
  PixelRandom other(42, 1234, 3);
  EXPECT_EQ(other.uniform() * 16777216.0f, 3530129.0f);
  // mixBits is SplitMix64's finaliser: mixBits(0) is the upper half of
  // SplitMix64's first output from state 0, 0xE220A8397B1DCDAF.
  EXPECT_EQ(mixBits(0), 0xE220A839u);
}

TEST(PixelRandom, PixelsStreamsAndSeedsDiffer) {
  const std::vector<float> base = draws(7, 500, 1, 64);
  EXPECT_LE(common(base, draws(7, 501, 1, 64)), 1) << "neighbouring pixel";
  EXPECT_LE(common(base, draws(7, 500 + 640, 1, 64)), 1) << "pixel one row down";
  EXPECT_LE(common(base, draws(7, 500, 2, 64)), 1) << "next stream";
  EXPECT_LE(common(base, draws(8, 500, 1, 64)), 1) << "next seed";
  // Swapping seed and pixel is not the same key.
  EXPECT_LE(common(draws(1, 2, 0, 64), draws(2, 1, 0, 64)), 1);
  // Across many pixels, the first draws are (nearly) all distinct.
  std::set<float> firsts;
  for (uint32_t p = 0; p < 4096; ++p) firsts.insert(draws(7, p, 1, 1)[0]);
  EXPECT_GE(firsts.size(), 4090u);  // birthday bound: ~0.5 expected collisions
}

TEST(PixelRandom, UniformInUnitIntervalWithMeanOneHalf) {
  PixelRandom rng(123, 77, 0);
  double sum = 0;
  float lo = 1, hi = 0;
  int bins[10] = {};
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const float u = rng.uniform();
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    sum += u;
    lo = std::min(lo, u);
    hi = std::max(hi, u);
    ++bins[static_cast<int>(u * 10)];
  }
  EXPECT_NEAR(sum / n, 0.5, 0.01);
  EXPECT_LT(lo, 1e-3f);
  EXPECT_GT(hi, 1 - 1e-3f);
  for (int b = 0; b < 10; ++b) EXPECT_NEAR(bins[b], n / 10, 500) << "bin " << b;  // ~5 sigma
}

TEST(PixelRandom, UniformRangeAndAcrossPixelsMean) {
  double sum = 0;
  const int pixels = 100000;
  for (uint32_t p = 0; p < pixels; ++p) {
    PixelRandom rng(9, p, 2);
    const float v = rng.uniform(-3.0f, 5.0f);
    ASSERT_GE(v, -3.0f);
    ASSERT_LT(v, 5.0f);
    sum += v;
  }
  // One draw per pixel, as the kernels do: mean 1 within 0.01 of the width 8.
  EXPECT_NEAR(sum / pixels, 1.0, 0.08);
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
