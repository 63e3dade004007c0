// The keyframe pose graph in builds without Ceres: the tracker's poses.
#include "amhmvs_mapping/mapping/keyframe_pose_graph.h"

namespace amhmvs {

bool keyframePoseGraphAvailable() { return false; }

std::map<int64_t, Eigen::Isometry3d> solveKeyframePoseGraph(const std::map<int64_t, Eigen::Isometry3d>& tracker_poses,
                                                            const std::vector<KeyframePoseGraphEdge>&,
                                                            const KeyframePoseGraphSettings&) {
  return tracker_poses;
}

}  // namespace amhmvs
