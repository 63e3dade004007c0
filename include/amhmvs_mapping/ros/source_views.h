// Source-view choice of the mapping nodelet (ROS-free adapter): the N most
// recent stored keyframes whose baseline to the new keyframe lies within
// [min_baseline, max_baseline] and whose optical axis is within max_angle_deg
// of the new one's. Kept in this one file so that it can be swapped for the
// mapping core's source_selection.h.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs_mapping {

struct SourceViewOptions {
  int num_sources = 4;         // N: at most this many source views
  double min_baseline = 0.05;  // metres
  double max_baseline = 10.0;  // metres
  double max_angle_deg = 45.0; // between optical axes

  // Empty when valid; otherwise what is wrong.
  std::string validate() const;
};

// Indices into `stored` (ordered oldest first) of the chosen source views,
// most recent first. Stored cameras with an invalid pose are skipped.
std::vector<size_t> chooseSourceViews(const amhmvs::PinholeCamera& target,
                                      const std::vector<const amhmvs::PinholeCamera*>& stored,
                                      const SourceViewOptions& options);

}  // namespace amhmvs_mapping
