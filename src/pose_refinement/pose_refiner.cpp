// PoseRefiner with OpenCV features and a Ceres bundle adjustment (the
// method: pose_refinement.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/stopwatch.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "feature_matching.h"
#include "star_bundle_adjustment.h"

namespace amhmvs {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

double rms(const std::vector<double>& errors) {
  if (errors.empty()) return 0;
  double squares = 0;
  for (double error : errors) squares += error * error;
  return std::sqrt(squares / errors.size());
}

// A source's tracker pose relative to the reference: X_ref = R X_src + C.
struct SourceInReference {
  Eigen::Matrix3d rotation;  // source to reference
  Eigen::Vector3d centre;
};

SourceInReference sourceInReference(const PinholeCamera& reference, const PinholeCamera& source) {
  return {reference.R * source.R.transpose(), reference.R * source.center() + reference.t};
}

// Sets the source camera's world pose from its refined pose relative to the
// (unchanged) reference: X_src = R^T (X_ref - C), X_ref = R_ref X + t_ref.
void setSourcePose(const PinholeCamera& reference, const SourceInReference& pose, PinholeCamera* source) {
  source->R = pose.rotation.transpose() * reference.R;
  source->t = pose.rotation.transpose() * (reference.t - pose.centre);
}

Eigen::Matrix3d rotationOf(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

// Step 3's decisions on a bundle adjustment whose sources start free (the
// ones with too few matches inactive): the points with the tracker's poses
// (a start near the solution), then the poses free; only the inliers of
// that solve are kept. Then, solved again after each change: a source with
// too few inliers left, or an implausible correction, keeps the tracker's
// pose and leaves; one whose refinement explains less than
// min_explained_rms_px of its epipolar error keeps the tracker's pose and
// stays as an anchor of the points (the features confirm the tracker).
std::vector<SourcePoseOutcome> adjustSources(const PoseRefinementOptions& options, StarBundleAdjustment* adjustment) {
  using State = StarBundleAdjustment::State;
  const int count = adjustment->sourceCount();
  std::vector<SourcePoseOutcome> outcome(count, SourcePoseOutcome::kTooFewMatches);
  adjustment->solve(/*poses_free=*/false);
  adjustment->solve(/*poses_free=*/true);
  for (int s = 0; s < count; ++s) {
    if (adjustment->state(s) != State::kFree) continue;
    adjustment->keepObservationsWithin(s, options.inlier_threshold_px);
    if (static_cast<int>(adjustment->observationCount(s)) < options.min_inliers) adjustment->setState(s, State::kInactive);
  }
  for (bool again = true; again;) {
    adjustment->solve(/*poses_free=*/true);
    again = false;
    for (int s = 0; s < count && !again; ++s) {
      if (adjustment->state(s) != State::kFree) continue;
      outcome[s] = SourcePoseOutcome::kRefined;
      const double shift = adjustment->centreCorrection(s).norm();
      const double angle_deg = adjustment->rotationCorrection(s).norm() * 180 / kPi;
      const double before = rms(adjustment->epipolarErrors(s, /*tracker_pose=*/true));
      const double after = rms(adjustment->epipolarErrors(s, /*tracker_pose=*/false));
      if (shift > options.max_correction_m || angle_deg > options.max_correction_deg) {
        outcome[s] = SourcePoseOutcome::kRejected;
        adjustment->setState(s, State::kInactive);
        again = true;
      } else if (std::sqrt(std::max(0.0, before * before - after * after)) < options.min_explained_rms_px) {
        outcome[s] = SourcePoseOutcome::kConfirmed;
        adjustment->setState(s, State::kFixed);
        again = true;
      }
    }
  }
  return outcome;
}

// The star's and the keyframes' adjustments take the same noise model and
// limits from the options.
template <typename Settings>
void copyAdjustmentSettings(const PoseRefinementOptions& options, Settings* settings) {
  settings->feature_sigma_px = options.feature_sigma_px;
  settings->huber_px = options.inlier_threshold_px;
  settings->prior_position_sigma_m = options.prior_position_sigma_m;
  settings->prior_rotation_sigma_rad = options.prior_rotation_sigma_deg * kPi / 180;
  settings->max_iterations = options.max_iterations;
}

// A match's position noise: its coarser feature's (finest_feature_size_px).
double matchSigmaPx(const PoseRefinementOptions& options, double reference_size, double source_size) {
  return featureSigmaPx(options.feature_sigma_px, std::max(reference_size, source_size),
                        options.finest_feature_size_px);
}

}  // namespace

class PoseRefiner::Impl {
 public:
  explicit Impl(const PoseRefinementOptions& options) : options_(options) {}

  PoseRefinementResult refine(DepthProblem* problem);
  KeyframeBundleAdjustmentResult adjustKeyframes(const std::map<int64_t, PinholeCamera>& cameras) const;
  void forget(int64_t key);
  void forgetAll() {
    cache_.clear();
    pair_matches_.clear();
  }
  size_t cached() const { return cache_.size(); }

 private:
  // The features of an image, from the cache when it has a key.
  std::shared_ptr<const ImageFeatures> features(const ImageViewU8& image, int64_t key, double* detect_ms);

  PoseRefinementOptions options_;
  std::map<int64_t, std::shared_ptr<const ImageFeatures>> cache_;
  // (reference key, source key) -> matched features, of the latest
  // refinement of the pair that refined or confirmed the source.
  std::map<std::pair<int64_t, int64_t>, std::vector<std::pair<int, int>>> pair_matches_;
};

void PoseRefiner::Impl::forget(int64_t key) {
  cache_.erase(key);
  for (auto pair = pair_matches_.begin(); pair != pair_matches_.end();) {
    if (pair->first.first == key || pair->first.second == key) pair = pair_matches_.erase(pair);
    else ++pair;
  }
}

KeyframeBundleAdjustmentResult PoseRefiner::Impl::adjustKeyframes(
    const std::map<int64_t, PinholeCamera>& cameras) const {
  std::map<int64_t, BundleKeyframe> keyframes;
  for (const auto& entry : cameras) {
    const auto features = cache_.find(entry.first);
    if (features == cache_.end()) continue;
    keyframes[entry.first] = {entry.second, features->second->pixels, features->second->sizes};
  }
  std::vector<KeyframeFeatureMatches> matches;
  for (const auto& pair : pair_matches_) matches.push_back({pair.first.first, pair.first.second, pair.second});
  KeyframeBundleAdjustmentSettings settings;
  copyAdjustmentSettings(options_, &settings);
  settings.min_explained_rms_px = options_.min_explained_rms_px;
  settings.finest_feature_size_px = options_.finest_feature_size_px;
  return amhmvs::adjustKeyframes(keyframes, matches, settings);
}

std::shared_ptr<const ImageFeatures> PoseRefiner::Impl::features(const ImageViewU8& image, int64_t key,
                                                                 double* detect_ms) {
  if (key != kNoImageKey) {
    const auto found = cache_.find(key);
    if (found != cache_.end()) return found->second;
  }
  const Clock::time_point start = Clock::now();
  auto detected = std::make_shared<const ImageFeatures>(detectFeatures(image, options_.max_features));
  *detect_ms += millisecondsSince(start);
  if (key != kNoImageKey) cache_[key] = detected;
  return detected;
}

PoseRefinementResult PoseRefiner::Impl::refine(DepthProblem* problem) {
  const Clock::time_point start = Clock::now();
  const std::string problems = problem->validate();
  if (!problems.empty()) throw InputError("pose refinement: invalid depth problem: " + problems);
  PoseRefinementResult result;
  result.ran = true;
  const PinholeCamera& reference = problem->reference_camera;
  const size_t source_count = problem->source_cameras.size();
  auto keyOf = [problem](size_t source) {
    return problem->source_keys.empty() ? kNoImageKey : problem->source_keys[source];
  };

  // 1-2: features and matches.
  const auto reference_features = features(problem->reference_image, problem->reference_key, &result.feature_ms);
  std::vector<MatchSet> matches(source_count);
  std::vector<std::shared_ptr<const ImageFeatures>> source_features(source_count);
  for (size_t s = 0; s < source_count; ++s) {
    source_features[s] = features(problem->source_images[s], keyOf(s), &result.feature_ms);
    const Clock::time_point match_start = Clock::now();
    matches[s] = matchFeatures(*reference_features, reference, *source_features[s], problem->source_cameras[s],
                               options_.ratio_test, options_.inlier_threshold_px);
    result.matching_ms += millisecondsSince(match_start);
    SourcePoseRefinement source;
    source.key = keyOf(s);
    source.matches = matches[s].ratio_matches;
    source.inliers = static_cast<int>(matches[s].inliers.size());
    result.sources.push_back(source);
  }

  // 3: the bundle adjustment over the reference features matched in an
  // active source (one with enough inliers).
  const Clock::time_point solve_start = Clock::now();
  std::map<int, int> point_of_feature;
  std::vector<Eigen::Vector3d> rays;
  for (size_t s = 0; s < source_count; ++s) {
    if (result.sources[s].inliers < options_.min_inliers) continue;
    for (const FeatureMatch& match : matches[s].inliers) {
      if (point_of_feature.count(match.reference)) continue;
      const Eigen::Vector2d& pixel = reference_features->pixels[match.reference];
      point_of_feature[match.reference] = static_cast<int>(rays.size());
      rays.emplace_back((pixel.x() - reference.cx) / reference.fx, (pixel.y() - reference.cy) / reference.fy, 1.0);
    }
  }
  result.points = static_cast<int>(rays.size());
  StarAdjustmentSettings settings;
  copyAdjustmentSettings(options_, &settings);
  // Points start in the middle of the depth range (in inverse depth) and may
  // go a factor of 4 beyond it.
  settings.inverse_depth_min = 0.25 / problem->depth_max;
  settings.inverse_depth_max = 4.0 / problem->depth_min;
  StarBundleAdjustment adjustment(std::move(rays), 0.5 / problem->depth_min + 0.5 / problem->depth_max, settings);
  std::vector<SourceInReference> tracker(source_count);
  for (size_t s = 0; s < source_count; ++s) {
    tracker[s] = sourceInReference(reference, problem->source_cameras[s]);
    std::vector<StarBundleAdjustment::Observation> observations;
    for (const FeatureMatch& match : matches[s].inliers) {
      const auto point = point_of_feature.find(match.reference);
      if (point != point_of_feature.end())
        observations.push_back({point->second, source_features[s]->pixels[match.source],
                                matchSigmaPx(options_, reference_features->sizes[match.reference],
                                             source_features[s]->sizes[match.source])});
    }
    adjustment.addSource(problem->source_cameras[s], tracker[s].rotation, tracker[s].centre, std::move(observations));
    if (result.sources[s].inliers < options_.min_inliers)
      adjustment.setState(static_cast<int>(s), StarBundleAdjustment::State::kInactive);
  }

  const std::vector<SourcePoseOutcome> outcome = adjustSources(options_, &adjustment);

  // The refined cameras and the report.
  for (size_t s = 0; s < source_count; ++s) {
    const int index = static_cast<int>(s);
    SourcePoseRefinement& report = result.sources[s];
    report.outcome = outcome[s];
    const bool agreed = outcome[s] == SourcePoseOutcome::kRefined || outcome[s] == SourcePoseOutcome::kConfirmed;
    if (problem->reference_key != kNoImageKey && keyOf(s) != kNoImageKey) {
      const std::pair<int64_t, int64_t> pair(problem->reference_key, keyOf(s));
      pair_matches_.erase(pair);
      if (agreed) {
        std::vector<std::pair<int, int>>& kept = pair_matches_[pair];
        for (const FeatureMatch& match : matches[s].inliers) kept.emplace_back(match.reference, match.source);
      }
    }
    if (!agreed) continue;
    report.inliers = static_cast<int>(adjustment.observationCount(index));
    report.rms_before_px = rms(adjustment.epipolarErrors(index, /*tracker_pose=*/true));
    report.rms_after_px = rms(adjustment.epipolarErrors(index, /*tracker_pose=*/false));
    if (outcome[s] != SourcePoseOutcome::kRefined) continue;
    report.correction_m = adjustment.centreCorrection(index).norm();
    report.correction_deg = adjustment.rotationCorrection(index).norm() * 180 / kPi;
    SourceInReference refined = tracker[s];
    refined.rotation = tracker[s].rotation * rotationOf(adjustment.rotationCorrection(index));
    refined.centre = tracker[s].centre + adjustment.centreCorrection(index);
    setSourcePose(reference, refined, &problem->source_cameras[s]);
  }
  result.solve_ms = millisecondsSince(solve_start);
  result.total_ms = millisecondsSince(start);
  return result;
}

bool PoseRefiner::available() { return true; }

PoseRefiner::PoseRefiner(const PoseRefinementOptions& options) : options_(options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("pose refinement options:\n" + problems);
  impl_ = std::make_unique<Impl>(options);
}

PoseRefiner::~PoseRefiner() = default;

PoseRefinementResult PoseRefiner::refine(DepthProblem* problem) { return impl_->refine(problem); }
KeyframeBundleAdjustmentResult PoseRefiner::adjustKeyframes(const std::map<int64_t, PinholeCamera>& cameras) const {
  return impl_->adjustKeyframes(cameras);
}
void PoseRefiner::forget(int64_t key) { impl_->forget(key); }
void PoseRefiner::forgetAll() { impl_->forgetAll(); }
size_t PoseRefiner::cachedImages() const { return impl_->cached(); }

}  // namespace amhmvs
