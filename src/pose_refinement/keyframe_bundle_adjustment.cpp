#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "pose_prior_residual.h"

namespace amhmvs {
namespace {

template <typename T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

// (pi(K R'^T (X - c')) - x) / sigma for one observation x.
struct ReprojectionResidual {
  Eigen::Matrix3d rotation;  // tracker, camera-to-world
  Eigen::Vector3d centre;    // tracker, world
  double fx, fy, cx, cy;
  Eigen::Vector2d pixel;
  double inverse_sigma;

  template <typename T>
  bool operator()(const T* w, const T* dc, const T* point, T* residual) const {
    const Vector3<T> offset(point[0] - (T(centre[0]) + dc[0]), point[1] - (T(centre[1]) + dc[1]),
                            point[2] - (T(centre[2]) + dc[2]));
    const Vector3<T> in_camera = correctedRotation(w, rotation).transpose() * offset;
    if (!(in_camera[2] > T(0))) return false;  // behind the camera: the step is refused
    residual[0] = (T(fx) * in_camera[0] / in_camera[2] + T(cx) - T(pixel.x())) * T(inverse_sigma);
    residual[1] = (T(fy) * in_camera[1] / in_camera[2] + T(cy) - T(pixel.y())) * T(inverse_sigma);
    return true;
  }
};

struct Observation {
  int64_t key;
  Eigen::Vector2d pixel;
  double sigma_px;  // the feature's position noise (featureSigmaPx)
  bool active = true;
};

struct Track {
  std::vector<Observation> observations;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int activeCount() const {
    return static_cast<int>(std::count_if(observations.begin(), observations.end(),
                                          [](const Observation& o) { return o.active; }));
  }
};

// Features joined into tracks; a join that would put two features of one
// keyframe into a track is refused (one of its matches is wrong), so a
// mismatch cannot chain two tracks into one.
class TrackSets {
 public:
  int add(int64_t key) {
    parent_.push_back(static_cast<int>(parent_.size()));
    keys_.push_back({key});
    return parent_.back();
  }
  int find(int node) {
    while (parent_[node] != node) node = parent_[node] = parent_[parent_[node]];
    return node;
  }
  void join(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    for (int64_t key : keys_[a])
      if (std::find(keys_[b].begin(), keys_[b].end(), key) != keys_[b].end()) return;
    if (keys_[a].size() > keys_[b].size()) std::swap(a, b);
    parent_[a] = b;
    keys_[b].insert(keys_[b].end(), keys_[a].begin(), keys_[a].end());
    keys_[a].clear();
  }

 private:
  std::vector<int> parent_;
  std::vector<std::vector<int64_t>> keys_;  // per root: the keyframes of its features
};

// Matches joined into tracks: features connected by a chain of matches.
std::vector<Track> buildTracks(const std::map<int64_t, BundleKeyframe>& keyframes,
                               const std::vector<KeyframeFeatureMatches>& matches,
                               const KeyframeBundleAdjustmentSettings& settings) {
  std::map<std::pair<int64_t, int>, int> node_of;
  std::vector<std::pair<int64_t, int>> feature_of;
  TrackSets sets;
  auto node = [&](int64_t key, int feature) {
    const auto found = node_of.emplace(std::make_pair(key, feature), 0);
    if (found.second) {
      found.first->second = sets.add(key);
      feature_of.push_back(found.first->first);
    }
    return found.first->second;
  };
  for (const KeyframeFeatureMatches& pair : matches) {
    const auto first = keyframes.find(pair.first), second = keyframes.find(pair.second);
    if (first == keyframes.end() || second == keyframes.end() || pair.first == pair.second) continue;
    const int first_count = static_cast<int>(first->second.pixels.size());
    const int second_count = static_cast<int>(second->second.pixels.size());
    for (const auto& match : pair.features) {
      if (match.first < 0 || match.first >= first_count || match.second < 0 || match.second >= second_count) continue;
      sets.join(node(pair.first, match.first), node(pair.second, match.second));
    }
  }
  std::map<int, Track> by_root;
  for (size_t n = 0; n < feature_of.size(); ++n) {
    const auto& feature = feature_of[n];
    const BundleKeyframe& keyframe = keyframes.at(feature.first);
    by_root[sets.find(static_cast<int>(n))].observations.push_back(
        {feature.first, keyframe.pixels[feature.second], featureSigmaPx(keyframe, feature.second, settings)});
  }
  std::vector<Track> tracks;
  for (auto& entry : by_root) {
    std::vector<Observation>& observations = entry.second.observations;
    if (observations.size() >= 2) tracks.push_back(std::move(entry.second));
  }
  return tracks;
}

Eigen::Vector3d rayOf(const PinholeCamera& camera, const Eigen::Vector2d& pixel) {
  return (camera.R.transpose() * camera.backproject(pixel.x(), pixel.y(), 1.0)).normalized();
}

// The point nearest to the active observations' rays (least squares);
// false when they meet at less than min_angle or the point is behind a camera.
bool triangulate(const std::map<int64_t, BundleKeyframe>& keyframes, double min_angle, Track* track) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> rays;
  for (const Observation& observation : track->observations) {
    if (!observation.active) continue;
    const BundleKeyframe& keyframe = keyframes.at(observation.key);
    const PinholeCamera& camera = keyframe.camera;
    rays.push_back(rayOf(camera, observation.pixel));
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - rays.back() * rays.back().transpose();
    normal += across;
    right += across * camera.center();
  }
  double widest_cos = 1;
  for (size_t i = 0; i < rays.size(); ++i)
    for (size_t j = i + 1; j < rays.size(); ++j) widest_cos = std::min(widest_cos, rays[i].dot(rays[j]));
  if (!(widest_cos < std::cos(min_angle))) return false;
  track->point = normal.ldlt().solve(right);
  for (const Observation& observation : track->observations) {
    if (observation.active && !(keyframes.at(observation.key).camera.toCamera(track->point).z() > 0)) return false;
  }
  return track->point.allFinite();
}

struct Correction {
  double w[3] = {0, 0, 0}, dc[3] = {0, 0, 0};
};

ReprojectionResidual residualOf(const BundleKeyframe& keyframe, const Observation& observation) {
  const PinholeCamera& camera = keyframe.camera;
  return {camera.R.transpose(), camera.center(), camera.fx, camera.fy, camera.cx, camera.cy, observation.pixel,
          1 / observation.sigma_px};
}

// Reprojection error in pixels (infinite behind the camera).
double errorPx(const BundleKeyframe& keyframe, const Observation& observation, const Correction& correction,
               const Eigen::Vector3d& point) {
  double value[2];
  const ReprojectionResidual residual = residualOf(keyframe, observation);
  if (!residual(correction.w, correction.dc, point.data(), value)) return INFINITY;
  return std::hypot(value[0], value[1]) / residual.inverse_sigma;
}

// The first solve weighs residuals with Cauchy's loss, whose pull fades with
// the error: mismatches far off cannot drag the poses (with Huber's, 20 % of
// them turned the poses by degrees in the unit test); the second, without
// them, with Huber's.
enum class Loss { kCauchy, kHuber };

// Keyframes in `held` keep the tracker's pose (their corrections stay 0).
bool solve(const std::map<int64_t, BundleKeyframe>& keyframes, const KeyframeBundleAdjustmentSettings& settings,
           Loss loss, const std::set<int64_t>& held, std::vector<Track>* tracks,
           std::map<int64_t, Correction>* corrections) {
  ceres::Problem problem;
  for (Track& track : *tracks) {
    if (track.activeCount() < 2) continue;
    for (const Observation& observation : track.observations) {
      if (!observation.active) continue;
      Correction& correction = (*corrections)[observation.key];
      const double scale = settings.huber_px / observation.sigma_px;  // huber_px in units of the residual
      ceres::LossFunction* robust = nullptr;
      if (loss == Loss::kCauchy)
        robust = new ceres::CauchyLoss(scale);
      else
        robust = new ceres::HuberLoss(scale);
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 3, 3, 3>(
                                   new ReprojectionResidual(residualOf(keyframes.at(observation.key), observation))),
                               robust, correction.w, correction.dc, track.point.data());
    }
  }
  if (problem.NumResidualBlocks() == 0) return false;
  addPosePriors(settings.prior_rotation_sigma_rad, settings.prior_position_sigma_m, corrections, &problem);
  for (auto& entry : *corrections) {
    if (!held.count(entry.first)) continue;
    problem.SetParameterBlockConstant(entry.second.w);
    problem.SetParameterBlockConstant(entry.second.dc);
  }
  return solveProblem(&problem, settings.max_iterations, ceres::SPARSE_SCHUR, ceres::DENSE_SCHUR);
}

// Squared reprojection errors of a keyframe's active observations: at the
// tracker's poses (points triangulated there) and after the adjustment.
struct ErrorSums {
  double before = 0, after = 0;
  int count = 0;
  void add(const ErrorSums& other) {
    before += other.before;
    after += other.after;
    count += other.count;
  }
  double rmsBeforePx() const { return std::sqrt(before / std::max(1, count)); }
  double rmsAfterPx() const { return std::sqrt(after / std::max(1, count)); }
  double explainedRmsPx() const { return std::sqrt(std::max(0.0, (before - after) / std::max(1, count))); }
};

std::map<int64_t, ErrorSums> keyframeErrors(const std::map<int64_t, BundleKeyframe>& keyframes,
                                            const std::vector<Track>& initial, const std::vector<Track>& tracks,
                                            const std::map<int64_t, Correction>& corrections) {
  std::map<int64_t, ErrorSums> sums;
  const Correction none;
  for (size_t t = 0; t < tracks.size(); ++t) {
    if (tracks[t].activeCount() < 2) continue;
    for (const Observation& observation : tracks[t].observations) {
      if (!observation.active) continue;
      const BundleKeyframe& keyframe = keyframes.at(observation.key);
      const auto correction = corrections.find(observation.key);
      ErrorSums& sum = sums[observation.key];
      sum.before += std::pow(std::min(errorPx(keyframe, observation, none, initial[t].point), 1e3), 2);
      sum.after += std::pow(std::min(errorPx(keyframe, observation,
                                             correction != corrections.end() ? correction->second : none,
                                             tracks[t].point),
                                     1e3),
                            2);
      ++sum.count;
    }
  }
  return sums;
}

}  // namespace

bool keyframeBundleAdjustmentAvailable() { return true; }

KeyframeBundleAdjustmentResult adjustKeyframes(const std::map<int64_t, BundleKeyframe>& keyframes,
                                               const std::vector<KeyframeFeatureMatches>& matches,
                                               const KeyframeBundleAdjustmentSettings& settings) {
  KeyframeBundleAdjustmentResult result;
  std::vector<Track> tracks;
  for (Track& track : buildTracks(keyframes, matches, settings)) {
    if (triangulate(keyframes, settings.min_ray_angle_rad, &track)) tracks.push_back(std::move(track));
  }
  std::map<int64_t, Correction> corrections;
  if (!solve(keyframes, settings, Loss::kCauchy, {}, &tracks, &corrections)) return result;
  // Observations far off after the first solve are mismatches: out, and
  // with them tracks left shorter than min_final_track_length; the second
  // solve starts from the tracker's poses and points triangulated there from
  // the observations that stay.
  for (Track& track : tracks) {
    for (Observation& observation : track.observations) {
      if (observation.active && errorPx(keyframes.at(observation.key), observation, corrections[observation.key],
                                        track.point) > 2 * settings.huber_px)
        observation.active = false;
    }
    const bool too_short = track.activeCount() < settings.min_final_track_length;
    if (too_short || !triangulate(keyframes, settings.min_ray_angle_rad, &track))
      for (Observation& observation : track.observations) observation.active = false;
  }
  const std::vector<Track> initial = tracks;
  corrections.clear();
  if (!solve(keyframes, settings, Loss::kHuber, {}, &tracks, &corrections)) return result;
  // A keyframe whose pose the adjustment explains less than
  // min_explained_rms_px of its features' error with is confirmed: the
  // features agree with the tracker there, and moving it would only fit
  // their noise (with exact poses this cost the realism map 15 points).
  // The others are solved again with the confirmed ones held.
  std::map<int64_t, ErrorSums> sums = keyframeErrors(keyframes, initial, tracks, corrections);
  std::set<int64_t> confirmed;
  for (const auto& entry : sums)
    if (entry.second.explainedRmsPx() < settings.min_explained_rms_px) confirmed.insert(entry.first);
  if (!confirmed.empty()) {
    tracks = initial;
    for (auto& entry : corrections) entry.second = Correction();
    if (confirmed.size() < corrections.size() &&
        !solve(keyframes, settings, Loss::kHuber, confirmed, &tracks, &corrections))
      return result;
    sums = keyframeErrors(keyframes, initial, tracks, corrections);
  }
  result.solved = true;
  result.confirmed = static_cast<int>(confirmed.size());
  ErrorSums all;
  for (const auto& entry : sums) all.add(entry.second);
  for (const Track& track : tracks) result.tracks += track.activeCount() >= 2;
  result.observations = all.count;
  result.rms_before_px = all.rmsBeforePx();
  result.rms_after_px = all.rmsAfterPx();
  for (const auto& entry : corrections) {
    result.poses[entry.first] =
        correctedPose(cameraToWorld(keyframes.at(entry.first).camera), entry.second.w, entry.second.dc);
  }
  return result;
}

}  // namespace amhmvs
