// Keyframe poses for the map (issue 12): the tracker's poses corrected by the
// relative poses that the pose refinement found (pose_refinement.h), so that
// the keyframes' points land where their neighbours' do.
//
// Each keyframe's depth map is estimated with its sources at refined
// relative poses, but placed in the map at the tracker's pose: the tracker's
// few millimetres and tenths of a degree of noise then spread the map's
// surfaces (on the realism room the exact depth maps placed at the tracker's
// poses are only 76 % within 2 cm of the true surface). The graph:
//   unknowns  per keyframe a correction of its camera-to-world pose:
//             R' = Exp(w) R (about its centre, world axes), c' = c + dc;
//   priors    the tracker's noise: w / prior_rotation_sigma,
//             dc / prior_position_sigma (the gauge, and the scale of every
//             translation together, which the features cannot see);
//   edges     per refined pair (reference i, source j) with measured
//             source-from-reference motion (R_ji, t_ji), the source's centre
//             C_ji = -R_ji^T t_ji in the reference frame:
//             Log(R_ji^T R'_j^T R'_i) / rotation_sigma, and
//             (R'_i^T (c'_j - c'_i) - s_i C_ji) / (direction_sigma |C_ji|)
//             with one free scale s_i per reference: each refinement fitted
//             the length of its star's translations to the tracker's poses
//             of that star only, so the graph takes their directions and
//             ratios (which fix a near-straight path's spacing, where
//             directions alone cannot) and fits the scale to all keyframes.
// Solved with Ceres (Levenberg-Marquardt, Huber-robust edges). Builds
// without Ceres return the tracker's poses (keyframePoseGraphAvailable()).
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <vector>

#include <Eigen/Geometry>

namespace amhmvs {

struct KeyframePoseGraphSettings {
  double prior_position_sigma_m = 0.01;
  double prior_rotation_sigma_rad = 0.3 * M_PI / 180;
  double rotation_sigma_rad = 0.05 * M_PI / 180;
  double direction_sigma_rad = 0.2 * M_PI / 180;
  int max_iterations = 50;
};

struct KeyframePoseGraphEdge {
  int64_t reference = 0, source = 0;
  Eigen::Isometry3d source_from_reference = Eigen::Isometry3d::Identity();  // X_source = T * X_reference
};

bool keyframePoseGraphAvailable();

// Corrected camera-to-world poses of the keyframes of `tracker_poses`
// (camera-to-world); edges naming other keyframes are ignored, keyframes
// without an edge keep the tracker's pose.
std::map<int64_t, Eigen::Isometry3d> solveKeyframePoseGraph(const std::map<int64_t, Eigen::Isometry3d>& tracker_poses,
                                                            const std::vector<KeyframePoseGraphEdge>& edges,
                                                            const KeyframePoseGraphSettings& settings);

}  // namespace amhmvs
