// The per-pixel part of the calibrated confidence (depth_confidence.h):
// the calibration table's lookup and the published (masked) depth, written
// once for the CPU loop (depth_confidence.cpp) and the CUDA kernel
// (cuda/cuda_fusion.cu), so that both publish the same pixels.
#pragma once

#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace confidence {

// A ConfidenceCalibration's table, borrowed (host or device memory).
struct TableView {
  const float* probability;  // cell(seen, agreeing, bin)
  const float* cost_edges;   // upper edges of the cost bins, ascending; the last bin is open
  int cost_edge_count;
  int max_views;             // seen and agreeing are capped at this

  AMHMVS_HD int costBin(float cost) const {
    int bin = 0;
    while (bin < cost_edge_count && !(cost < cost_edges[bin])) ++bin;  // NaN: the last bin
    return bin;
  }
  AMHMVS_HD int cell(int seen, int agreeing, int bin) const {
    return (seen * (max_views + 1) + agreeing) * (cost_edge_count + 1) + bin;
  }
  // The probability of a pixel's evidence (counts capped here).
  AMHMVS_HD float lookup(int seen, int agreeing, float cost) const {
    seen = seen < 0 ? 0 : (seen > max_views ? max_views : seen);
    agreeing = agreeing < 0 ? 0 : (agreeing > seen ? seen : agreeing);
    return probability[cell(seen, agreeing, costBin(cost))];
  }
};

AMHMVS_HD bool hasDepth(float depth) {
#if defined(__CUDA_ARCH__)
  return isfinite(depth) && depth > 0;
#else
  return std::isfinite(depth) && depth > 0;
#endif
}

// A pixel's confidence: the table's probability where it has a depth, else 0.
AMHMVS_HD float pixelConfidence(const TableView& table, int seen, int agreeing, float depth, float cost) {
  return hasDepth(depth) ? table.lookup(seen, agreeing, cost) : 0.0f;
}

// The depth as published: NaN where the confidence is below the level.
AMHMVS_HD float publishedDepth(float depth, float confidence, float min_probability) {
  return confidence >= min_probability ? depth : nanf("");
}

}  // namespace confidence
}  // namespace amhmvs
