#include "amhmvs_mapping/mvs/propagation_pattern.h"

namespace amhmvs {
namespace mvs {
namespace {

// Prototype regions, written for the upward direction (dy < 0).
constexpr PixelOffset kNearVUp[] = {{0, -1}, {-1, -2}, {1, -2}, {-2, -3},
                                    {2, -3}, {-3, -4}, {3, -4}};
constexpr int kFarLineLength = 11;  // distances 3, 5, ..., 23
constexpr int kSymmetricNear = 1;
constexpr int kSymmetricFar = 5;

// The four directions as maps of an upward offset (dx, dy): up, down, left, right.
PixelOffset rotate(PixelOffset up, int direction) {
  switch (direction) {
    case 0: return {up.dx, up.dy};                                         // up
    case 1: return {up.dx, static_cast<int8_t>(-up.dy)};                   // down
    case 2: return {up.dy, up.dx};                                         // left
    default: return {static_cast<int8_t>(-up.dy), up.dx};                  // right
  }
}

}  // namespace

PropagationPattern makePropagationPattern(PropagationScheme scheme) {
  PropagationPattern pattern{};
  int count = 0;
  auto add = [&](PixelOffset up, int direction) { pattern.offsets[count++] = rotate(up, direction); };
  for (int region = 0; region < kNumRegions; ++region) {
    pattern.begin[region] = count;
    const int direction = region % 4;
    const bool near = region < 4;
    if (scheme == PropagationScheme::kAsymmetric) {
      if (near) {
        for (const PixelOffset& o : kNearVUp) add(o, direction);
      } else {
        for (int k = 0; k < kFarLineLength; ++k) add({0, static_cast<int8_t>(-(3 + 2 * k))}, direction);
      }
    } else {
      add({0, static_cast<int8_t>(near ? -kSymmetricNear : -kSymmetricFar)}, direction);
    }
  }
  pattern.begin[kNumRegions] = count;
  return pattern;
}

}  // namespace mvs
}  // namespace amhmvs
