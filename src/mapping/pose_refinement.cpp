// PoseRefinementOptions, its option table and the result's summaries: in
// every build (the refiner itself is in src/pose_refinement/).
#include "amhmvs_mapping/mapping/pose_refinement.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace amhmvs {

std::string PoseRefinementOptions::validate() const {
  std::ostringstream why;
  auto require = [&why](bool ok, const char* name, double value, const char* rule) {
    if (!ok) why << name << " must be " << rule << " (got " << value << ")\n";
  };
  require(max_features >= 8, "max_features", max_features, ">= 8");
  require(ratio_test > 0 && ratio_test <= 1, "ratio_test", ratio_test, "in (0, 1]");
  require(std::isfinite(inlier_threshold_px) && inlier_threshold_px > 0, "inlier_threshold_px", inlier_threshold_px,
          "finite and > 0");
  require(min_inliers >= 6, "min_inliers", min_inliers, ">= 6 (a relative pose has 5 degrees of freedom)");
  require(std::isfinite(feature_sigma_px) && feature_sigma_px > 0, "feature_sigma_px", feature_sigma_px,
          "finite and > 0");
  require(std::isfinite(finest_feature_size_px) && finest_feature_size_px >= 0, "finest_feature_size_px",
          finest_feature_size_px, "finite and >= 0 (0: off)");
  require(std::isfinite(prior_position_sigma_m) && prior_position_sigma_m > 0, "prior_position_sigma_m",
          prior_position_sigma_m, "finite and > 0");
  require(std::isfinite(prior_rotation_sigma_deg) && prior_rotation_sigma_deg > 0, "prior_rotation_sigma_deg",
          prior_rotation_sigma_deg, "finite and > 0");
  require(max_iterations >= 1, "max_iterations", max_iterations, ">= 1");
  require(std::isfinite(min_explained_rms_px) && min_explained_rms_px >= 0, "min_explained_rms_px",
          min_explained_rms_px, "finite and >= 0");
  require(std::isfinite(max_correction_m) && max_correction_m > 0, "max_correction_m", max_correction_m,
          "finite and > 0");
  require(std::isfinite(max_correction_deg) && max_correction_deg > 0 && max_correction_deg <= 180,
          "max_correction_deg", max_correction_deg, "in (0, 180]");
  require(std::isfinite(graph_rotation_sigma_deg) && graph_rotation_sigma_deg > 0, "graph_rotation_sigma_deg",
          graph_rotation_sigma_deg, "finite and > 0");
  require(std::isfinite(graph_direction_sigma_deg) && graph_direction_sigma_deg > 0, "graph_direction_sigma_deg",
          graph_direction_sigma_deg, "finite and > 0");
  require(max_pose_reestimates >= 0, "max_pose_reestimates", max_pose_reestimates, ">= 0");
  require(reestimate_length_change > 0 && reestimate_length_change < 1, "reestimate_length_change",
          reestimate_length_change, "in (0, 1)");
  return why.str();
}

const std::vector<PoseRefinementOptionInfo>& poseRefinementOptionTable() {
  using O = PoseRefinementOptions;
  static const std::vector<PoseRefinementOptionInfo> table = {
      switchField<O>("enabled", &O::enabled,
                  "refine each keyframe's poses relative to its sources before stereo (features + bundle "
                  "adjustment; depth, clouds and map stay in the tracker's frame)"),
      numberField("max_features", &O::max_features, "SIFT features per keyframe image"),
      numberField("ratio_test", &O::ratio_test, "a match's best / second-best descriptor distance, at most"),
      numberField("inlier_threshold_px", &O::inlier_threshold_px,
                  "RANSAC and final reprojection inlier threshold, pixels"),
      numberField("min_inliers", &O::min_inliers, "fewer inliers: the source keeps the tracker's pose"),
      numberField("feature_sigma_px", &O::feature_sigma_px,
                  "reprojection noise of a match, pixels (weighs the matches against the prior)"),
      numberField("finest_feature_size_px", &O::finest_feature_size_px,
                  "a feature of size s (diameter, px) weighs with sigma feature_sigma_px * max(1, s / this); "
                  "0 = every feature at feature_sigma_px"),
      numberField("prior_position_sigma_m", &O::prior_position_sigma_m,
                  "prior: the tracker's noise, expected error of each keyframe's position, std dev per axis, m"),
      numberField("prior_rotation_sigma_deg", &O::prior_rotation_sigma_deg,
                  "prior: the tracker's noise, expected error of each keyframe's rotation, std dev per axis, deg"),
      numberField("max_iterations", &O::max_iterations, "bundle-adjustment iterations per solve"),
      numberField("min_explained_rms_px", &O::min_explained_rms_px,
                  "a source keeps the tracker's pose unless the refinement explains this much of its epipolar "
                  "error, sqrt(RMS before^2 - after^2), pixels"),
      numberField("max_correction_m", &O::max_correction_m,
                  "a larger shift of a source's centre is rejected (the tracker's pose stays), m"),
      numberField("max_correction_deg", &O::max_correction_deg,
                  "a larger rotation of a source is rejected (the tracker's pose stays), deg"),
      switchField<O>("in_fusion", &O::in_fusion,
                  "the fusion's consistency check and the confidence take the neighbours at the refined relative "
                  "poses (the points stay at the tracker's pose)"),
      switchField<O>("correct_map_poses", &O::correct_map_poses,
                  "the map places each keyframe at its pose corrected by a graph of all refined relative poses "
                  "(the tracker's as priors); depth images and published clouds keep the tracker's pose"),
      numberField("graph_rotation_sigma_deg", &O::graph_rotation_sigma_deg,
                  "correct_map_poses: std dev of a refined pair's relative rotation, deg"),
      numberField("graph_direction_sigma_deg", &O::graph_direction_sigma_deg,
                  "correct_map_poses: std dev of a refined pair's baseline direction, deg"),
      switchField<O>("keyframe_bundle_adjustment", &O::keyframe_bundle_adjustment,
                  "instead of the graph: one bundle adjustment over the matches of all stored keyframes after each "
                  "refinement; its poses place the map and are the stereo's and the fusion's relative poses"),
      numberField("max_pose_reestimates", &O::max_pose_reestimates,
                  "keyframe_bundle_adjustment: re-estimates per keyframe when the adjustment moves its sources "
                  "(0.01 deg, 0.05 deg of direction or reestimate_length_change of length); 0 = never"),
      numberField("reestimate_length_change", &O::reestimate_length_change,
                  "keyframe_bundle_adjustment: a source's baseline length change (fraction) that re-estimates "
                  "the keyframe"),
  };
  return table;
}

bool operator==(const PoseRefinementOptions& a, const PoseRefinementOptions& b) {
  for (const PoseRefinementOptionInfo& option : poseRefinementOptionTable())
    if (option.get(a) != option.get(b)) return false;
  return true;
}

const char* PoseRefiner::unavailableMessage() {
  return "this build has no pose refinement: it needs OpenCV features2d and Ceres (libopencv-dev, libceres-dev)";
}

const char* sourcePoseOutcomeName(SourcePoseOutcome outcome) {
  switch (outcome) {
    case SourcePoseOutcome::kRefined: return "refined";
    case SourcePoseOutcome::kConfirmed: return "confirmed";
    case SourcePoseOutcome::kTooFewMatches: return "too_few_matches";
    case SourcePoseOutcome::kRejected: return "rejected";
  }
  return "unknown";
}

namespace {

template <typename Predicate>
int countSources(const std::vector<SourcePoseRefinement>& sources, Predicate keep) {
  return static_cast<int>(std::count_if(sources.begin(), sources.end(), keep));
}

// RMS over the refined sources' inliers of one of their RMS fields.
double pooledRms(const std::vector<SourcePoseRefinement>& sources, double SourcePoseRefinement::*rms) {
  double squares = 0;
  int count = 0;
  for (const SourcePoseRefinement& source : sources) {
    if (source.outcome != SourcePoseOutcome::kRefined) continue;
    squares += source.*rms * source.*rms * source.inliers;
    count += source.inliers;
  }
  return count > 0 ? std::sqrt(squares / count) : 0.0;
}

double maxOverRefined(const std::vector<SourcePoseRefinement>& sources, double SourcePoseRefinement::*value) {
  double largest = 0;
  for (const SourcePoseRefinement& source : sources)
    if (source.outcome == SourcePoseOutcome::kRefined) largest = std::max(largest, source.*value);
  return largest;
}

}  // namespace

int PoseRefinementResult::refinedCount() const {
  return countSources(sources, [](const SourcePoseRefinement& s) { return s.outcome == SourcePoseOutcome::kRefined; });
}
int PoseRefinementResult::rejectedCount() const {
  return countSources(sources, [](const SourcePoseRefinement& s) { return s.outcome == SourcePoseOutcome::kRejected; });
}
double PoseRefinementResult::rmsBeforePx() const { return pooledRms(sources, &SourcePoseRefinement::rms_before_px); }
double PoseRefinementResult::rmsAfterPx() const { return pooledRms(sources, &SourcePoseRefinement::rms_after_px); }
double PoseRefinementResult::maxCorrectionM() const {
  return maxOverRefined(sources, &SourcePoseRefinement::correction_m);
}
double PoseRefinementResult::maxCorrectionDeg() const {
  return maxOverRefined(sources, &SourcePoseRefinement::correction_deg);
}

}  // namespace amhmvs
