// Counter-based random numbers: a pure function of (seed, pixel, iteration,
// draw). No state is carried between draws, so the CPU and GPU backends draw
// exactly the same numbers for a pixel whatever the thread schedule, and a run
// is reproducible bit for bit for a given seed.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

AMHMVS_HD uint32_t mixBits(uint64_t z) {
  // SplitMix64 finaliser: a bijective avalanche of all input bits.
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<uint32_t>(z >> 32);
}

struct PixelRandom {
  uint64_t key;      // seed and pixel
  uint32_t counter;  // iteration and draw index

  AMHMVS_HD PixelRandom(uint32_t seed, uint32_t pixel, uint32_t stream)
      : key((static_cast<uint64_t>(seed) << 32) | pixel), counter(stream << 16) {}

  // Uniform in [0, 1): 24 random bits, exact in float.
  AMHMVS_HD float uniform() {
    const uint32_t bits = mixBits(key ^ (static_cast<uint64_t>(counter++) * 0xD1B54A32D192ED03ull));
    return static_cast<float>(bits >> 8) * (1.0f / 16777216.0f);
  }
  AMHMVS_HD float uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }
};

}  // namespace mvs
}  // namespace amhmvs
