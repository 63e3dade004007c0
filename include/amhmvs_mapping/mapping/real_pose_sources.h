// Source ranking for real poses at the image sizes the CPU runs at: what the
// nodelet's shipped config/mapping.yaml and amhmvs_map use (the core's
// SourceSelectionOptions keep MVSNet's values for exact poses).
//
// Real poses (SLAM, KinectFusion) are off by 1-5 px. At 256-320 px and 1 deg
// of triangulation angle one pixel is ~25 % of the depth, at 2 deg ~13 %:
// pairs need at least 2 deg, and the ranking prefers 8 deg rather than
// MVSNet's 5 (exact DTU poses at 1600 px). Measured on redkitchen (100
// frames, 256 px, 23 keyframes): with the scene depth from the data, 1 / 5 deg
// gave 30.6 % of the pixels within 5 % and a map 33.7 % within 2 cm; 2 / 8 deg
// 34.5 % and 45.5 % (the fixed 3 m scene depth before, which underestimated
// the angles of this 1.6-1.9 m scene: 35.1 % and 44.6 %).
#pragma once

#include "amhmvs_mapping/mapping/source_selection.h"

namespace amhmvs {

constexpr double kRealPoseMinTriangulationAngleDeg = 2.0;
constexpr double kRealPosePreferredAngleDeg = 8.0;

// SourceSelectionOptions() with the two angles above.
inline SourceSelectionOptions realPoseSourceSelection() {
  SourceSelectionOptions options;
  options.min_triangulation_angle_deg = kRealPoseMinTriangulationAngleDeg;
  options.preferred_angle_deg = kRealPosePreferredAngleDeg;
  return options;
}

}  // namespace amhmvs
