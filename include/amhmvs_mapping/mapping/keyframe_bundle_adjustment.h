// One bundle adjustment over all stored keyframes (issue 12): the feature
// matches of every pose refinement (pose_refinement.h) joined into tracks,
// so that every keyframe's poses share one scale.
//
// Each refinement fits its star (a reference and its sources) to the
// tracker's poses of that star alone; the star's translations, and so the
// keyframe's depth map, then carry their own scale error (the realism room:
// 0.5-1.7 %, several cm at 2 m), and the keyframe pose graph
// (keyframe_pose_graph.h) cannot take it out. Here the matches of all stars
// become tracks across keyframes:
//   unknowns  per keyframe a correction of its camera-to-world pose,
//             R' = Exp(w) R, c' = c + dc (as the pose graph's), and per
//             track a world point X;
//   residuals (pi(K R'^T (X - c')) - x) / feature_sigma for every
//             observation x of a track (Cauchy's loss at huber_px in the
//             first solve, Huber's in the second), and the
//             tracker's noise as a prior on every correction:
//             w / prior_rotation_sigma, dc / prior_position_sigma (the
//             gauge, and the one scale of the whole map).
// Matches are joined into tracks unless the join would give a track two
// features of one keyframe (then one of the matches is wrong: refused).
// Tracks start triangulated at the tracker's poses; one whose rays meet at
// less than min_ray_angle is left out; after a first solve the observations
// off by more than 2 huber_px leave (and tracks shorter than
// min_final_track_length), the tracks are triangulated again from the rest
// and all is solved again from the tracker's poses. Keyframes whose
// features the solve explains less than min_explained_rms_px of their error
// with keep the tracker's pose, and the rest is solved once more.
// Builds without Ceres return no poses (keyframeBundleAdjustmentAvailable()).
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs {

struct KeyframeBundleAdjustmentSettings {
  // Position noise of the finest features (size at most finest_feature_size_px).
  double feature_sigma_px = 0.5;
  // Coarser features are noisier in proportion to their size, and biased:
  // a blob's centre is not where the surface point projects once the views
  // see the surface from other angles (perspective). A feature of size s
  // (BundleKeyframe::sizes) weighs with sigma = feature_sigma_px *
  // max(1, s / finest_feature_size_px); 0: every feature at feature_sigma_px.
  double finest_feature_size_px = 0;
  double huber_px = 1.5;
  double prior_position_sigma_m = 0.01;
  double prior_rotation_sigma_rad = 0.3 * M_PI / 180;
  double min_ray_angle_rad = 0.5 * M_PI / 180;
  // Observations a track needs in the final solve: a wrong match in a
  // two-view track fits anyway along the epipolar line and bends the poses
  // (unit test, 20 % wrong matches: 0.2-0.5 deg with 2, 0.05-0.2 with 3).
  int min_final_track_length = 3;
  // A keyframe keeps the tracker's pose (confirmed) when the adjustment
  // explains less than this of its features' reprojection error,
  // sqrt(RMS before^2 - RMS after^2) (the star refinement's rule).
  double min_explained_rms_px = 0.25;
  int max_iterations = 50;
};

// A keyframe: its camera at the tracker's pose and its features' pixels
// (index = feature number of the matches).
struct BundleKeyframe {
  PinholeCamera camera;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<double> sizes;  // per feature, its diameter in pixels; empty: all of the finest size
};

// The position noise of a feature of size `size_px`: feature_sigma_px *
// max(1, size_px / finest_feature_size_px); feature_sigma_px when
// finest_feature_size_px is 0 (the star's and the keyframes' adjustments).
inline double featureSigmaPx(double feature_sigma_px, double size_px, double finest_feature_size_px) {
  if (!(finest_feature_size_px > 0)) return feature_sigma_px;
  return feature_sigma_px * std::max(1.0, size_px / finest_feature_size_px);
}
// A keyframe's feature's (one without a size: the finest).
inline double featureSigmaPx(const BundleKeyframe& keyframe, int feature,
                             const KeyframeBundleAdjustmentSettings& settings) {
  const bool sized = feature >= 0 && feature < static_cast<int>(keyframe.sizes.size());
  return featureSigmaPx(settings.feature_sigma_px, sized ? keyframe.sizes[feature] : 0,
                        settings.finest_feature_size_px);
}

// Matched features of two keyframes: (feature of `first`, feature of `second`).
struct KeyframeFeatureMatches {
  int64_t first = 0, second = 0;
  std::vector<std::pair<int, int>> features;
};

struct KeyframeBundleAdjustmentResult {
  bool solved = false;
  // Corrected camera-to-world poses of the keyframes that observe a track.
  std::map<int64_t, Eigen::Isometry3d> poses;
  int tracks = 0;        // in the final solve
  int confirmed = 0;     // keyframes held at the tracker's pose (min_explained_rms_px)
  int observations = 0;  // in the final solve
  double rms_before_px = 0;  // of those observations: at the tracker's poses (points triangulated there)
  double rms_after_px = 0;   // after the adjustment
};

bool keyframeBundleAdjustmentAvailable();

// Matches naming a keyframe that is not in `keyframes`, or a feature beyond
// its pixels, are ignored.
KeyframeBundleAdjustmentResult adjustKeyframes(const std::map<int64_t, BundleKeyframe>& keyframes,
                                               const std::vector<KeyframeFeatureMatches>& matches,
                                               const KeyframeBundleAdjustmentSettings& settings);

}  // namespace amhmvs
