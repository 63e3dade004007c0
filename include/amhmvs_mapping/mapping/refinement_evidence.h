// Whether a refined depth map should replace the one a keyframe has, by the
// estimator's own evidence, its aggregated matching cost (0..2, lower is
// better): new sources can be worse than the old ones (later keyframes only,
// wider angles, pose error), and then the re-estimate is worse too.
//
// The new map is kept when it has at least (1 - max_confident_loss) times as
// many confident pixels (valid depth, cost <= confident_cost) as the old map.
// The median cost on the pixels valid in both is reported, not judged: the
// aggregated cost is a weighted mean over the selected views, so more sources
// raise it even where they help (redkitchen: 0.10-0.13 -> 0.12-0.15 for
// refinements with more sources and more confident pixels). When there is
// nothing to compare (no cost image, or the old map has no valid pixel) the
// new map is kept.
#pragma once

#include <cstddef>
#include <string>

#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct DepthMapEvidence {
  size_t confident_pixels = 0;  // valid depth with cost <= confident_cost
  double median_cost = 0;       // over the pixels valid in both maps (0 when none)
};

struct RefinementVerdict {
  bool keep_new = true;
  DepthMapEvidence old_map, new_map;
  size_t common_pixels = 0;  // valid in both
  std::string reason;        // e.g. "median cost 0.41 -> 0.55, confident pixels 5120 -> 3900"
};

// Both maps must have the same size (InputError otherwise).
RefinementVerdict judgeRefinement(const DepthMap& old_map, const DepthMap& new_map, double confident_cost,
                                  double max_confident_loss);

}  // namespace amhmvs
