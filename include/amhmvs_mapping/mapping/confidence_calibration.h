// The calibration of the per-pixel depth confidence (depth_confidence.h):
// a table from multi-view evidence to the probability that a pixel's depth
// is within `within` (5 %) of the truth, fitted on realism-mode synthetic
// sequences (exact ground truth, a tracker's pose noise) and checked on
// redkitchen (README, "Confidence and the published depth").
//
// Evidence of a pixel with a depth estimate, against its keyframe's
// consistency views (the other depth maps it is fused against):
//   seen     -- views that see its 3D point (in front, inside the image);
//   agreeing -- of those, the views whose estimate there agrees under
//               `checks` (fusion_pixel.h checkSource: reprojection error,
//               relative depth difference, normal angle);
//   cost     -- its matching cost (0..2), in bins.
// Both counts are capped at max_views. The table is only valid with the
// checks it was fitted with, so they are part of it, not options.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/confidence_pixel.h"
#include "amhmvs_mapping/mapping/fusion.h"

namespace amhmvs {

struct ConfidenceCalibration {
  FusionOptions checks;          // when a view agrees (min_consistent_views unused)
  double within = 0.05;          // the probability is of |d - d_true| / d_true < within
  int max_views = 4;             // seen and agreeing counted up to this
  std::vector<float> cost_edges;  // upper edges of the cost bins, ascending; the last bin is open
  // Probability per cell, index cell(seen, agreeing, bin); cells with
  // agreeing > seen cannot occur.
  std::vector<float> probability;

  int costBins() const { return static_cast<int>(cost_edges.size()) + 1; }
  int costBin(float cost) const;
  size_t cellCount() const { return static_cast<size_t>((max_views + 1) * (max_views + 1) * costBins()); }
  size_t cell(int seen, int agreeing, int bin) const;
  // The probability of a pixel's evidence (counts capped here).
  float lookup(int seen, int agreeing, float cost) const { return view().lookup(seen, agreeing, cost); }
  // The table as the per-pixel code reads it (borrows this one's vectors).
  confidence::TableView view() const {
    return {probability.data(), cost_edges.data(), static_cast<int>(cost_edges.size()), max_views};
  }
  // Empty when usable; otherwise what is wrong.
  std::string validate() const;
};

// The table committed in confidence_calibration.cpp (with the command that
// regenerates it).
const ConfidenceCalibration& defaultConfidenceCalibration();

// Counts per cell for fitting a table: samples with ground truth.
class ConfidenceFit {
 public:
  // `shape`: checks, within, max_views and cost bins of the table to fit.
  explicit ConfidenceFit(const ConfidenceCalibration& shape);
  void add(int seen, int agreeing, float cost, double relative_error);
  void merge(const ConfidenceFit& other);
  // The fitted table: (within + 1) / (samples + 2) per cell (no sample: 0.5).
  ConfidenceCalibration table() const;
  size_t samples(size_t cell) const { return samples_[cell]; }
  size_t within(size_t cell) const { return within_[cell]; }
  const ConfidenceCalibration& shape() const { return shape_; }

 private:
  ConfidenceCalibration shape_;
  std::vector<size_t> samples_, within_;
};

// The table as C++ initialiser lines (one per (seen, agreeing), a comment
// with the sample counts), for confidence_calibration.cpp.
std::string calibrationSource(const ConfidenceFit& fit);

}  // namespace amhmvs
