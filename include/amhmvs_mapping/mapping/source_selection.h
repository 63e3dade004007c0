// Source-view selection for a new keyframe by baseline and viewing angle (the
// paper's "N preselected according to viewing angle and baseline", sec. 3.2).
//
// For each candidate keyframe, at the scene depth d of the new (target)
// keyframe (scene_depth.h: sparse points, depth range, depth maps, patches
// matched along epipolar lines, a default):
//   - baseline: distance of the camera centres; below 1e-3 d the pair cannot
//     triangulate (pure rotation or duplicate pose);
//   - optical-axis angle must be <= max_axis_angle_deg;
//   - overlap: fraction of an overlap_grid x overlap_grid grid of target
//     pixels, back-projected to z-depth d, that project inside the candidate
//     (in front of it); must be >= min_overlap;
//   - triangulation angle: median over the visible grid points of the angle
//     between the rays from both centres; must lie in
//     [min_triangulation_angle_deg, max_triangulation_angle_deg].
// Qualified candidates are ranked by score = overlap * G(angle), with the
// MVSNet piecewise Gaussian G(a) = exp(-(a - a0)^2 / (2 s^2)), a0 =
// preferred_angle_deg, s = sigma_below_deg for a <= a0 and sigma_above_deg
// above; ties by ascending id (deterministic). The best max_sources are kept.
//
// The overlap grid is the costly part. Beyond max_candidates candidates that
// pass the cheap checks (pose, optical axes), only the max_candidates best at
// the target's centre pixel (seen there, then the triangulation angle nearest
// the preferred one) are evaluated in full; the others are rejected as such.
// Among a store's keyframes, only the nearestCandidateCount() whose camera
// centres lie nearest the target's are candidates at all (good sources sit
// within a few baselines of the target; a keyframe far away sees the scene at
// another scale or angle). Selection then costs about the same in a store of
// 50 keyframes and of 5,000.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/scene_depth.h"

namespace amhmvs {

// The scene-depth options are its base: options.default_scene_depth etc.
struct SourceSelectionOptions : SceneDepthOptions {
  // The paper's Strecha runs use all 10 other views; 8 keeps online depth
  // estimation cheaper while giving the joint view selection enough choice.
  int max_sources = 8;
  double min_triangulation_angle_deg = 1.0;
  double max_triangulation_angle_deg = 30.0;
  double max_axis_angle_deg = 45.0;
  double min_overlap = 0.3;          // fraction in (0, 1]
  double preferred_angle_deg = 5.0;  // MVSNet theta0
  double sigma_below_deg = 1.0;      // MVSNet sigma1
  double sigma_above_deg = 10.0;     // MVSNet sigma2
  int overlap_grid = 12;             // grid samples per image side
  int max_candidates = 32;           // evaluated in full (the overlap grid), at most

  // Empty when valid (scene-depth options included); otherwise one line per problem.
  std::string validate() const;
};

struct SourceViewCandidate {
  int64_t id = 0;
  double baseline_m = 0;
  double axis_angle_deg = 0;
  double triangulation_angle_deg = 0;
  double overlap = 0;     // fraction
  double score = 0;       // 0 when rejected
  std::string rejection;  // empty when selected; e.g. "overlap 12 % < 30 %"
};

struct SourceSelection {
  std::vector<int64_t> source_ids;  // best first, at most max_sources
  // Every candidate: the selected in rank order, then the rejected by id.
  std::vector<SourceViewCandidate> candidates;
  SceneDepth scene_depth;
  std::string reason;  // why nothing was selected; empty when source_ids is not
};

// Selects sources for `target` among `candidates` (a candidate with the
// target's id is ignored), at the scene depth the keyframe alone gives
// (sceneDepth(keyframe): sparse points, depth range, default). Throws InputError for invalid options, an invalid
// target camera or a null candidate; an invalid candidate is rejected with
// its reason.
SourceSelection selectSources(const Keyframe& target,
                              const std::vector<const Keyframe*>& candidates,
                              const SourceSelectionOptions& options = SourceSelectionOptions());

// How many of a store's keyframes, those nearest the target, are candidates
// for selectSources(store, target_id, options): 4 x max_candidates.
size_t nearestCandidateCount(const SourceSelectionOptions& options);

// Selects among the stored keyframes `candidate_ids`, at the scene depth of
// every rule of scene_depth.h (their depth maps and images included); throws
// InputError for an unknown id.
SourceSelection selectSources(const KeyframeStore& store, int64_t target_id,
                              const std::vector<int64_t>& candidate_ids,
                              const SourceSelectionOptions& options = SourceSelectionOptions());

// Same, among the nearestCandidateCount(options) other keyframes of the
// store nearest the target.
SourceSelection selectSources(const KeyframeStore& store, int64_t target_id,
                              const SourceSelectionOptions& options = SourceSelectionOptions());

}  // namespace amhmvs
