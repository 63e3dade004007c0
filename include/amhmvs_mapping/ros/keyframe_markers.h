// rviz markers of the mapping nodelet: the stored keyframes' frusta and the
// links from the newest keyframe to its chosen source views.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs_mapping {

struct MarkerCamera {
  int64_t id = 0;
  amhmvs::PinholeCamera camera;  // intrinsics and world-to-camera pose
};

// Two LINE_LIST markers in header.frame_id (the fixed frame): namespace
// "frusta" (id 0: every camera's pyramid, apex at its centre, base = the image
// corners at z-depth frustum_depth) and "source_links" (id 0: a line from the
// newest camera's centre to each of its sources' centres). Cameras with an
// invalid pose are left out; unknown source ids are skipped.
visualization_msgs::MarkerArray keyframeMarkers(const std::vector<MarkerCamera>& cameras, int64_t newest_id,
                                                const std::vector<int64_t>& source_ids, double frustum_depth,
                                                const std_msgs::Header& header);

}  // namespace amhmvs_mapping
