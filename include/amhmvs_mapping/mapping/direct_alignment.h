// Direct (photometric) alignment of a keyframe's sources to it before stereo
// (not in the paper). A real tracker's relative poses are 2-3 px off at
// keyframe baselines, and a photometric estimator then matches the wrong
// pixels. Each source that has a depth map already (an earlier keyframe) is
// aligned to the reference image: its confident, textured pixels are moved
// into the reference by the relative pose and compared there; the pose and an
// affine brightness change (exposure) minimise the robust (Huber) sum of the
// grey-level differences, coarse to fine over an image pyramid
// (Levenberg-Marquardt; per point: direct_alignment_pixel.h).
//
// Only the problem's source cameras change: the reference keeps the
// tracker's pose, so the depth map, the clouds and the map stay in the
// tracker's frame. A source keeps the tracker's pose when it has no depth
// map, too few points, a correction beyond max_correction_*, or when the
// alignment does not lower the cost.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/option_field.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct DirectAlignmentOptions {
  // Off by default: neither mode below wins at both of redkitchen's trackers.
  bool enabled = false;
  // Only the motion across epipolar lines is aligned (direct_alignment_pixel.h).
  // Off: the whole pose, which wins where the tracker's baselines are right
  // (redkitchen at KinectFusion's poses) but follows the sources' depth
  // errors where they are not (at a frame-to-frame odometry's, ~10 % of a
  // baseline); on: the reverse (docs/accuracy.md, "Direct alignment").
  bool across_epipolar_only = false;
  int levels = 4;                  // pyramid levels (each half the size of the one below)
  int iterations = 12;             // Levenberg-Marquardt steps per level, at most
  double min_gradient = 4.0;       // a source pixel's grey-level gradient (per pixel of its level), at least
  double max_cost = 0.5;           // a source pixel's matching cost (0..2), at most
  int max_points = 6000;           // per source and level (evenly thinned beyond)
  int min_points = 300;            // fewer at the finest level: the tracker's pose stays
  double huber_grey = 8.0;         // residuals beyond this many grey levels weigh less (Huber)
  double max_correction_m = 0.1;   // a larger shift of the source's centre: the tracker's pose stays
  double max_correction_deg = 3.0; // a larger rotation: the tracker's pose stays

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

using DirectAlignmentOptionInfo = OptionField<DirectAlignmentOptions>;
const std::vector<DirectAlignmentOptionInfo>& directAlignmentOptionTable();

enum class SourceAlignmentOutcome {
  kAligned,       // its pose was corrected
  kNoDepth,       // no surface (depth map or fused points) yet: the tracker's pose
  kTooFewPoints,  // too few confident textured pixels in view: the tracker's pose
  kNotBetter,     // the alignment did not lower the cost: the tracker's pose
  kRejected,      // the correction was implausibly large: the tracker's pose
};
const char* sourceAlignmentOutcomeName(SourceAlignmentOutcome outcome);

struct SourceAlignment {
  int points = 0;                 // at the finest level
  double rms_before_grey = 0;     // RMS residual of the points at the tracker's pose (no brightness change)
  double rms_after_grey = 0;      // at the aligned pose and brightness (when aligned)
  double correction_m = 0;        // shift of the source's centre
  double correction_deg = 0;      // rotation of the source
  // Median image shift of the points that the correction makes in the
  // reference, across and along the tracker's epipolar lines (pixels).
  double shift_across_px = 0, shift_along_px = 0;
  double gain = 1, bias = 0;      // the brightness change, reference = gain * source + bias
  SourceAlignmentOutcome outcome = SourceAlignmentOutcome::kNoDepth;
};

struct DirectAlignmentResult {
  bool ran = false;
  std::vector<SourceAlignment> sources;  // one per source of the problem, in order
  double total_ms = 0;
  int alignedCount() const;
};

// Aligns problem->source_cameras[s] to the reference for every s with a
// surface: source_surfaces[s] are points of the source's surface in its
// camera frame (its fused points, or confidentDepthPoints); empty: none, the
// tracker's pose. Throws InputError for an invalid problem or options, or a
// source_surfaces of the wrong length.
DirectAlignmentResult alignSourcesDirectly(DepthProblem* problem,
                                           const std::vector<std::vector<Eigen::Vector3f>>& source_surfaces,
                                           const DirectAlignmentOptions& options);

// The pixels of a depth map (with cost, at the camera's size) whose matching
// cost is at most max_cost, as points in the camera frame; none when the
// sizes differ.
std::vector<Eigen::Vector3f> confidentDepthPoints(const DepthMap& depth, const PinholeCamera& camera,
                                                  double max_cost);

}  // namespace amhmvs
