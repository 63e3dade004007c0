#include "amhmvs_mapping/mapping/view_anchor.h"

#include <cmath>
#include <vector>

#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {

bool viewAnchor(const PinholeCamera& camera, const ImageF& depth, Eigen::Vector3d* anchor) {
  std::vector<double> valid;
  for (float d : depth.data)
    if (std::isfinite(d) && d > 0) valid.push_back(d);
  if (valid.empty()) return false;
  const Eigen::Isometry3d camera_to_world = cameraToWorld(camera);
  *anchor = camera_to_world * Eigen::Vector3d(0, 0, medianOf(valid));
  return true;
}

}  // namespace amhmvs
