#include "amhmvs_mapping/eval/trajectory_error.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"

namespace amhmvs {

namespace {

double rootMeanSquare(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v * v;
  return std::sqrt(sum / values.size());
}

// The value below which `fraction` of the sample lies (nearest rank).
double quantile(std::vector<double> values, double fraction) {
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(std::ceil(fraction * values.size()));
  return values[std::min(values.size() - 1, rank > 0 ? rank - 1 : 0)];
}

// The rigid motion (no scale) that best carries the estimated centres onto
// the reference ones (Umeyama).
Eigen::Isometry3d rigidAlignment(const std::vector<Eigen::Isometry3d>& from, const std::vector<Eigen::Isometry3d>& to) {
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (size_t i = 0; i < from.size(); ++i) {
    a.col(i) = from[i].translation();
    b.col(i) = to[i].translation();
  }
  Eigen::Isometry3d alignment;
  alignment.matrix() = Eigen::umeyama(a, b, false);
  return alignment;
}

// Median over the sampled pixels of `depth` of how far apart they land in
// the second view with the two relative poses (second-to-first, camera-to-camera);
// NaN without a sample.
double pairMisalignment(const ImageF& depth, const PinholeCamera& camera, const Eigen::Isometry3d& reference,
                        const Eigen::Isometry3d& estimated, int stride) {
  const Eigen::Isometry3d to_reference = reference.inverse(), to_estimated = estimated.inverse();
  std::vector<double> distances;
  for (int y = stride / 2; y < depth.height; y += stride) {
    for (int x = stride / 2; x < depth.width; x += stride) {
      const float d = depth.at(x, y);
      if (!(d > 0) || !std::isfinite(d)) continue;
      const Eigen::Vector3d point = camera.backproject(x, y, d);
      const Eigen::Vector3d in_reference = to_reference * point, in_estimated = to_estimated * point;
      if (in_reference.z() <= 0 || in_estimated.z() <= 0) continue;
      distances.push_back((camera.project(in_reference) - camera.project(in_estimated)).norm());
    }
  }
  return distances.empty() ? TrajectoryError::kNaN : medianOf(distances);
}

}  // namespace

std::string TrajectoryErrorOptions::validate() const {
  std::string why = keyframes.validate();
  if (pixel_stride < 1) why += "pixel_stride must be at least 1 (got " + std::to_string(pixel_stride) + ")\n";
  return why;
}

TrajectoryError trajectoryError(const std::vector<Eigen::Isometry3d>& estimated,
                                const std::vector<Eigen::Isometry3d>& reference, const PinholeCamera& camera,
                                const std::function<ImageF(size_t)>& depth, const TrajectoryErrorOptions& options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("invalid trajectory error options:\n" + problems);
  if (estimated.size() != reference.size()) {
    throw InputError("trajectory error: " + std::to_string(estimated.size()) + " estimated poses against " +
                     std::to_string(reference.size()) + " reference poses");
  }
  if (estimated.size() < 2) throw InputError("trajectory error: needs at least 2 poses");
  TrajectoryError error;
  error.poses = estimated.size();

  const Eigen::Isometry3d alignment = rigidAlignment(estimated, reference);
  std::vector<double> centre_errors;
  for (size_t i = 0; i < estimated.size(); ++i) {
    centre_errors.push_back(((alignment * estimated[i]).translation() - reference[i].translation()).norm());
  }
  error.ate_rmse_m = rootMeanSquare(centre_errors);
  error.ate_median_m = medianOf(centre_errors);
  error.ate_max_m = *std::max_element(centre_errors.begin(), centre_errors.end());

  KeyframePicker picker(options.keyframes);
  for (size_t i = 0; i < reference.size(); ++i) {
    if (picker.offer(reference[i], {}) == PickDecision::kKeyframe) error.keyframes.push_back(i);
  }
  std::vector<double> translations, rotations, misalignments;
  for (size_t k = 1; k < error.keyframes.size(); ++k) {
    const size_t a = error.keyframes[k - 1], b = error.keyframes[k];
    const Eigen::Isometry3d true_relative = reference[a].inverse() * reference[b];
    const Eigen::Isometry3d estimated_relative = estimated[a].inverse() * estimated[b];
    const Eigen::Isometry3d difference = true_relative.inverse() * estimated_relative;
    translations.push_back(difference.translation().norm());
    rotations.push_back(rotationAngleDeg(difference.rotation()));
    const ImageF first = depth ? depth(a) : ImageF();
    if (first.data.empty()) continue;
    const double pixels = pairMisalignment(first, camera, true_relative, estimated_relative, options.pixel_stride);
    if (std::isfinite(pixels)) misalignments.push_back(pixels);
  }
  error.keyframe_pairs = translations.size();
  if (!translations.empty()) {
    error.rpe_translation_rmse_m = rootMeanSquare(translations);
    error.rpe_rotation_rmse_deg = rootMeanSquare(rotations);
    error.rpe_translation_max_m = *std::max_element(translations.begin(), translations.end());
    error.rpe_rotation_max_deg = *std::max_element(rotations.begin(), rotations.end());
  }
  error.misalignment_pairs = misalignments.size();
  if (!misalignments.empty()) {
    error.misalignment_median_px = medianOf(misalignments);
    error.misalignment_p90_px = quantile(misalignments, 0.9);
    error.misalignment_max_px = *std::max_element(misalignments.begin(), misalignments.end());
  }
  return error;
}

std::string trajectoryErrorJson(const TrajectoryError& error) {
  const std::pair<const char*, double> fields[] = {
      {"poses", error.poses},
      {"ate_rmse_m", error.ate_rmse_m},
      {"ate_median_m", error.ate_median_m},
      {"ate_max_m", error.ate_max_m},
      {"keyframe_pairs", error.keyframe_pairs},
      {"rpe_translation_rmse_m", error.rpe_translation_rmse_m},
      {"rpe_rotation_rmse_deg", error.rpe_rotation_rmse_deg},
      {"rpe_translation_max_m", error.rpe_translation_max_m},
      {"rpe_rotation_max_deg", error.rpe_rotation_max_deg},
      {"misalignment_pairs", error.misalignment_pairs},
      {"misalignment_median_px", error.misalignment_median_px},
      {"misalignment_p90_px", error.misalignment_p90_px},
      {"misalignment_max_px", error.misalignment_max_px},
  };
  std::ostringstream out;
  out.precision(6);
  out << "{";
  const char* separator = "\n";
  for (const auto& [name, value] : fields) {
    out << separator << "  \"" << name << "\": ";
    if (std::isfinite(value)) {
      out << value;
    } else {
      out << "null";  // JSON has no NaN
    }
    separator = ",\n";
  }
  out << "\n}\n";
  return out.str();
}

}  // namespace amhmvs
