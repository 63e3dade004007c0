// Refinement of a keyframe's poses relative to its source views, for the
// stereo only (issue 12: a tracker's poses disagree with the images by a few
// pixels, and a photometric method then matches the wrong pixels):
//
//   1. features of every keyframe image (OpenCV SIFT: subpixel positions),
//      detected once per image key and cached until forget(key);
//   2. the reference's features matched to each source's (Lowe's ratio test,
//      then RANSAC on the essential matrix of the normalised points);
//   3. a small bundle adjustment (Ceres): the reference camera held; free
//      are each source's pose relative to the reference (a rotation about
//      the source's centre and a shift of that centre, in the reference
//      frame) and the inverse depth of each matched reference feature; the
//      residuals are robust (Huber) reprojection errors in the sources plus
//      the tracker's noise (prior_*_sigma) as a prior on every keyframe's own
//      pose error, the reference's included: what the features cannot see
//      (the scale of all translations together) becomes the best fit to all
//      the tracker's poses.
//      A source whose correction exceeds max_correction_* keeps the
//      tracker's pose (rejected); so does one whose refinement explains less
//      than min_explained_rms_px of its epipolar error (confirmed: the
//      features agree with the tracker; it stays in the adjustment as an
//      anchor); the others are solved again after each such decision.
//
// Only the DepthProblem's source cameras change: the reference camera keeps
// the tracker's pose, so the depth map (camera frame), and the clouds and
// map placed with the keyframe's pose, stay in the tracker's frame.
//
// The implementation needs OpenCV features2d/calib3d and Ceres; builds
// without them (the core-only build of the GPU machine) compile a stub:
// PoseRefiner::available() is false and refine() says so in its result.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/option_field.h"
#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct PoseRefinementOptions {
  // Off by default: it wins back the pose noise of a jittery tracker (the
  // realism mode: 26.5 -> 94.6 % of pixels within 5 %), but on redkitchen's
  // KinectFusion poses it does not help (38.9 -> 38.0 %) and costs fused map
  // points, and its features cost more than a GPU estimate (README).
  bool enabled = false;
  // --- Features and matches ---
  int max_features = 500;             // SIFT features per keyframe image (the strongest)
  double ratio_test = 0.8;            // best / second-best descriptor distance, at most
  double inlier_threshold_px = 1.5;   // RANSAC (essential matrix) and final reprojection inliers
  int min_inliers = 20;               // fewer matches left: the source keeps the tracker's pose
  // --- Bundle adjustment ---
  double feature_sigma_px = 0.5;      // reprojection noise of a match (weighs matches against the prior)
  // Coarse SIFT features are blobs whose centre moves with the viewing angle
  // (perspective), not only noisier: a feature of size s (diameter, pixels)
  // weighs with sigma = feature_sigma_px * max(1, s / finest_feature_size_px),
  // a match with its coarser feature's. 0: all at feature_sigma_px. On sharp
  // images (the realism room without blur, noise or rolling shutter) the
  // keyframe adjustment's relative rotations then stay within 0.013 deg of
  // the truth instead of turning 0.2-0.4 % too far; off by default, as the
  // realism default profile loses with it (README "Coarse features").
  double finest_feature_size_px = 0;
  // The tracker's noise: expected error of each keyframe's pose, std dev
  // per axis of its position (metres) and of its rotation (degrees).
  double prior_position_sigma_m = 0.01;
  double prior_rotation_sigma_deg = 0.3;
  int max_iterations = 30;            // Levenberg-Marquardt iterations per solve
  // A source keeps the tracker's pose unless its refinement explains at least
  // this much of its epipolar error, sqrt(RMS before^2 - RMS after^2): with
  // exact poses the features' own noise explains ~0.1 px.
  double min_explained_rms_px = 0.25;
  // A larger correction is taken for a failure: that source keeps the tracker's pose.
  double max_correction_m = 0.1;
  double max_correction_deg = 3.0;
  // --- After stereo ---
  // The fusion's consistency check and the confidence's agreement count take
  // a keyframe's neighbours at the refined relative poses (refined_relative_poses.h);
  // the points stay at the tracker's pose.
  bool in_fusion = true;
  // The map places each keyframe's points at its pose corrected by a graph
  // of all the refined relative poses (keyframe_pose_graph.h): the tracker's
  // poses as priors (prior_*_sigma), each refined pair's relative rotation
  // and baseline direction as edges of these std devs. Depth images and
  // published clouds keep the tracker's pose.
  bool correct_map_poses = false;
  double graph_rotation_sigma_deg = 0.05;
  double graph_direction_sigma_deg = 0.2;
  // Instead of the graph: one bundle adjustment over the matches of all
  // stored keyframes (keyframe_bundle_adjustment.h) after each refinement.
  // Its poses place the keyframes in the map, and its relative poses are
  // the stereo's and the fusion's, so that the depth maps' scale and their
  // placement agree. Depth images and published clouds keep the tracker's pose.
  bool keyframe_bundle_adjustment = false;
  // keyframe_bundle_adjustment: a keyframe is estimated again (up to this
  // many times) once the adjustment has moved one of its sources relative to
  // it by more than 0.01 deg, 0.05 deg of baseline direction or
  // reestimate_length_change of baseline length (each ~0.3 % of depth at a
  // 3 deg parallax): the scale settles as keyframes arrive. 0: never.
  int max_pose_reestimates = 8;
  // A source's baseline length change (fraction) that re-estimates the
  // keyframe: a depth map keeps up to this much of an early solve's scale.
  double reestimate_length_change = 2e-3;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// The options by text (name, meaning, accessors): the single list behind
// amhmvs_map's --pose_refinement_<name>, the nodelet's pose_refinement/<name>
// and config/mapping.yaml.
using PoseRefinementOptionInfo = OptionField<PoseRefinementOptions>;
const std::vector<PoseRefinementOptionInfo>& poseRefinementOptionTable();
// Equal in every option of the table.
bool operator==(const PoseRefinementOptions& a, const PoseRefinementOptions& b);
inline bool operator!=(const PoseRefinementOptions& a, const PoseRefinementOptions& b) { return !(a == b); }

// What happened to one source view.
enum class SourcePoseOutcome {
  kRefined,        // its pose was refined
  kConfirmed,      // the features agree with the tracker's pose (min_explained_rms_px): kept
  kTooFewMatches,  // fewer than min_inliers matches: the tracker's pose
  kRejected,       // the correction was implausibly large: the tracker's pose
};
const char* sourcePoseOutcomeName(SourcePoseOutcome outcome);

struct SourcePoseRefinement {
  int64_t key = 0;                 // the source's image key (keyframe id)
  int matches = 0;                 // after the ratio test
  int inliers = 0;                 // after RANSAC and the bundle adjustment's reprojection check
  // RMS distance of the inliers from their epipolar lines (the error stereo
  // suffers; refined and confirmed sources, else 0) with the tracker's pose
  // and with the refined one.
  double rms_before_px = 0;
  double rms_after_px = 0;
  double correction_m = 0;         // shift of the source's centre
  double correction_deg = 0;       // rotation of the source
  SourcePoseOutcome outcome = SourcePoseOutcome::kTooFewMatches;
};

struct PoseRefinementResult {
  bool ran = false;       // false: off, or unavailable in this build (see `note`)
  std::string note;       // why it did not run, when it did not
  std::vector<SourcePoseRefinement> sources;  // one per source of the problem, in order
  int points = 0;         // reference features in the bundle adjustment
  double feature_ms = 0;  // detection (0 when every image was cached)
  double matching_ms = 0;
  double solve_ms = 0;
  double total_ms = 0;

  int refinedCount() const;
  int rejectedCount() const;
  // Over the refined sources' inliers (0 when none).
  double rmsBeforePx() const;
  double rmsAfterPx() const;
  // The largest correction among the refined sources.
  double maxCorrectionM() const;
  double maxCorrectionDeg() const;
};

class PoseRefiner {
 public:
  // True when this build has the implementation (OpenCV features2d and Ceres).
  static bool available();
  // The message of builds without it.
  static const char* unavailableMessage();

  // Throws InputError when the options are invalid.
  explicit PoseRefiner(const PoseRefinementOptions& options);
  ~PoseRefiner();
  PoseRefiner(const PoseRefiner&) = delete;
  PoseRefiner& operator=(const PoseRefiner&) = delete;

  // Refines the poses of problem->source_cameras relative to the reference
  // camera (which does not change). Features of images with a key
  // (problem->reference_key, source_keys) are cached until forget(key).
  // Throws InputError for an invalid problem.
  PoseRefinementResult refine(DepthProblem* problem);

  // The bundle adjustment of all keyframes (keyframe_bundle_adjustment.h)
  // over the cached features and the matches of every refined or confirmed
  // pair since their keys were cached; `cameras` are the keyframes at the
  // tracker's poses, by image key (others are left out).
  KeyframeBundleAdjustmentResult adjustKeyframes(const std::map<int64_t, PinholeCamera>& cameras) const;

  // Drops the cached features and matches of an image key (its keyframe left the store).
  void forget(int64_t key);
  void forgetAll();
  size_t cachedImages() const;
  const PoseRefinementOptions& options() const { return options_; }

 private:
  class Impl;
  PoseRefinementOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace amhmvs
