#include "amhmvs_mapping/mapping/refinement_evidence.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"

namespace amhmvs {
namespace {

bool validDepth(float depth) { return std::isfinite(depth) && depth > 0; }

size_t validPixels(const ImageF& depth) {
  size_t count = 0;
  for (float d : depth.data) count += validDepth(d);
  return count;
}

}  // namespace

RefinementVerdict judgeRefinement(const DepthMap& old_map, const DepthMap& new_map, double confident_cost,
                                  double max_confident_loss) {
  RefinementVerdict verdict;
  if (!new_map.depth.sameSize(old_map.depth.width, old_map.depth.height)) {
    throw InputError("refinement: the new depth map's size differs from the old one's");
  }
  if (old_map.cost.empty() || new_map.cost.empty() || validPixels(old_map.depth) == 0) {
    verdict.reason = "nothing to compare (no cost image or no valid old pixel)";
    return verdict;
  }
  std::vector<double> old_costs, new_costs;  // on the pixels valid in both
  const size_t pixels = old_map.depth.pixelCount();
  for (size_t i = 0; i < pixels; ++i) {
    const bool old_valid = validDepth(old_map.depth.data[i]), new_valid = validDepth(new_map.depth.data[i]);
    const float old_cost = old_map.cost.data[i], new_cost = new_map.cost.data[i];
    verdict.old_map.confident_pixels += old_valid && old_cost <= confident_cost;
    verdict.new_map.confident_pixels += new_valid && new_cost <= confident_cost;
    if (old_valid && new_valid && std::isfinite(old_cost) && std::isfinite(new_cost)) {
      old_costs.push_back(old_cost);
      new_costs.push_back(new_cost);
    }
  }
  verdict.common_pixels = old_costs.size();
  if (!old_costs.empty()) {
    verdict.old_map.median_cost = medianOf(old_costs);
    verdict.new_map.median_cost = medianOf(new_costs);
  }
  verdict.keep_new = static_cast<double>(verdict.new_map.confident_pixels) >=
                     (1 - max_confident_loss) * static_cast<double>(verdict.old_map.confident_pixels);
  std::ostringstream reason;
  reason.precision(3);
  reason << "confident pixels " << verdict.old_map.confident_pixels << " -> " << verdict.new_map.confident_pixels
         << ", median cost " << verdict.old_map.median_cost << " -> " << verdict.new_map.median_cost << " on "
         << verdict.common_pixels << " common pixels";
  verdict.reason = reason.str();
  return verdict;
}

}  // namespace amhmvs
