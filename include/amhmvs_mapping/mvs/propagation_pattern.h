// Checkerboard propagation patterns (paper section 3.1) as one table.
//
// Pixels are coloured by (x + y) mod 2; all pixels of one colour are updated
// in parallel from candidates of the other colour, so every offset here has an
// odd dx + dy: an update never reads a pixel that the same pass writes.
//
// Asymmetric pattern (the paper's default), 8 regions around a pixel:
//  - 4 near "V" regions of 7 candidates, opening away from the pixel. The
//    upward V is (0,-1) (-1,-2) (1,-2) (-2,-3) (2,-3) (-3,-4) (3,-4); the
//    others are its rotations by 90 degree steps.
//  - 4 far straight lines of 11 candidates at distances 3, 5, ..., 23.
// From each region the candidate with the lowest current cost is taken, giving
// up to 8 hypotheses. Near the border a region has fewer candidates, and one
// with none contributes no hypothesis.
//
// Symmetric pattern (ablation "\ACP" of the paper's Table 1): Gipuma's fast
// checkerboard neighbours, one fixed candidate per region: distance 1 (near)
// and distance 5 (far) along the four axes.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs {
namespace mvs {

constexpr int kNumRegions = 8;
constexpr int kMaxPatternOffsets = 4 * 7 + 4 * 11;

struct PixelOffset {
  int8_t dx, dy;
};

// Regions are stored back to back: region r owns offsets
// [begin[r], begin[r + 1]). Order: near up, near down, near left, near right,
// far up, far down, far left, far right.
struct PropagationPattern {
  int begin[kNumRegions + 1];
  PixelOffset offsets[kMaxPatternOffsets];

  AMHMVS_HD int regionSize(int region) const { return begin[region + 1] - begin[region]; }
};

// Builds the table for a scheme from the prototypes above.
PropagationPattern makePropagationPattern(PropagationScheme scheme);

}  // namespace mvs
}  // namespace amhmvs
