#include "star_bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>
#include <limits>

#include "pose_prior_residual.h"

namespace amhmvs {
namespace {

// The source pixel of a reference feature (the equation in the header):
// ray r, inverse depth rho, correction (w, dc) of the source's pose, whose
// tracker pose is R (source to reference, as R^T row-major) and C. False
// when the point is not in front of the source.
template <typename T>
bool projectIntoSource(const double* ray, const double* rotation_from_reference, const double* centre,
                       const double* intrinsics, const T* w, const T* dc, const T* rho, T* pixel) {
  T offset[3];
  for (int i = 0; i < 3; ++i) offset[i] = T(ray[i]) - rho[0] * (T(centre[i]) + dc[i]);
  T in_source[3];
  for (int row = 0; row < 3; ++row) {
    in_source[row] = T(rotation_from_reference[3 * row]) * offset[0] +
                     T(rotation_from_reference[3 * row + 1]) * offset[1] +
                     T(rotation_from_reference[3 * row + 2]) * offset[2];
  }
  const T minus_w[3] = {-w[0], -w[1], -w[2]};
  T point[3];
  ceres::AngleAxisRotatePoint(minus_w, in_source, point);
  if (!(point[2] > T(0))) return false;
  pixel[0] = T(intrinsics[0]) * point[0] / point[2] + T(intrinsics[2]);
  pixel[1] = T(intrinsics[1]) * point[1] / point[2] + T(intrinsics[3]);
  return true;
}

// What one observation needs, in plain arrays for the templated code.
struct ObservationGeometry {
  double ray[3];
  double rotation_from_reference[9];  // R^T, row-major
  double centre[3];
  double intrinsics[4];               // fx, fy, cx, cy
  double pixel[2];
};

struct ReprojectionResidual {
  ObservationGeometry geometry;
  double inverse_sigma = 1;

  template <typename T>
  bool operator()(const T* w, const T* dc, const T* rho, T* residual) const {
    T projected[2];
    if (!projectIntoSource(geometry.ray, geometry.rotation_from_reference, geometry.centre, geometry.intrinsics, w,
                           dc, rho, projected)) {
      return false;
    }
    residual[0] = (projected[0] - T(geometry.pixel[0])) * T(inverse_sigma);
    residual[1] = (projected[1] - T(geometry.pixel[1])) * T(inverse_sigma);
    return true;
  }
};

// A source's own pose error (small angles, reference frame): the star's
// rigid motion (w_r, dc_r) carries it by w_r and w_r x C, its correction
// adds R w and dc.
struct SourcePriorResidual {
  double rotation_to_reference[9];  // R, row-major
  double centre[3];                 // C
  double inverse_rotation_sigma = 1, inverse_position_sigma = 1;

  template <typename T>
  bool operator()(const T* w_r, const T* dc_r, const T* w, const T* dc, T* residual) const {
    T turned[3];
    for (int row = 0; row < 3; ++row) {
      turned[row] = T(rotation_to_reference[3 * row]) * w[0] + T(rotation_to_reference[3 * row + 1]) * w[1] +
                    T(rotation_to_reference[3 * row + 2]) * w[2];
    }
    const T carried[3] = {w_r[1] * T(centre[2]) - w_r[2] * T(centre[1]), w_r[2] * T(centre[0]) - w_r[0] * T(centre[2]),
                          w_r[0] * T(centre[1]) - w_r[1] * T(centre[0])};
    for (int i = 0; i < 3; ++i) {
      residual[i] = (w_r[i] + turned[i]) * T(inverse_rotation_sigma);
      residual[3 + i] = (dc_r[i] + carried[i] + dc[i]) * T(inverse_position_sigma);
    }
    return true;
  }
};

}  // namespace

StarBundleAdjustment::StarBundleAdjustment(std::vector<Eigen::Vector3d> rays, double initial_inverse_depth,
                                           const StarAdjustmentSettings& settings)
    : rays_(std::move(rays)), inverse_depths_(rays_.size(), initial_inverse_depth), settings_(settings) {}

int StarBundleAdjustment::addSource(const PinholeCamera& intrinsics, const Eigen::Matrix3d& rotation_to_reference,
                                    const Eigen::Vector3d& centre_in_reference, std::vector<Observation> observations) {
  Source source;
  source.fx = intrinsics.fx;
  source.fy = intrinsics.fy;
  source.cx = intrinsics.cx;
  source.cy = intrinsics.cy;
  source.rotation_to_reference = rotation_to_reference;
  source.centre_in_reference = centre_in_reference;
  source.observations = std::move(observations);
  sources_.push_back(std::move(source));
  return static_cast<int>(sources_.size()) - 1;
}

namespace {

ObservationGeometry geometryOf(const Eigen::Vector3d& ray, const Eigen::Matrix3d& rotation_to_reference,
                               const Eigen::Vector3d& centre, double fx, double fy, double cx, double cy,
                               const Eigen::Vector2d& pixel) {
  ObservationGeometry g;
  const Eigen::Matrix3d from_reference = rotation_to_reference.transpose();
  for (int i = 0; i < 3; ++i) {
    g.ray[i] = ray[i];
    g.centre[i] = centre[i];
    for (int j = 0; j < 3; ++j) g.rotation_from_reference[3 * i + j] = from_reference(i, j);
  }
  g.intrinsics[0] = fx;
  g.intrinsics[1] = fy;
  g.intrinsics[2] = cx;
  g.intrinsics[3] = cy;
  g.pixel[0] = pixel.x();
  g.pixel[1] = pixel.y();
  return g;
}

}  // namespace

void StarBundleAdjustment::solve(bool poses_free) {
  ceres::Problem problem;  // owns the cost and loss functions
  std::vector<bool> used(rays_.size(), false);
  for (Source& source : sources_) {
    if (source.state == State::kInactive || source.observations.empty()) continue;
    for (const Observation& observation : source.observations) {
      auto* residual = new ReprojectionResidual;
      residual->geometry = geometryOf(rays_[observation.point], source.rotation_to_reference,
                                      source.centre_in_reference, source.fx, source.fy, source.cx, source.cy,
                                      observation.pixel);
      const double sigma = observation.sigma_px > 0 ? observation.sigma_px : settings_.feature_sigma_px;
      residual->inverse_sigma = 1.0 / sigma;
      // In units of this observation's sigma, like its residual: robust beyond huber_px.
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 3, 3, 1>(residual),
                               new ceres::HuberLoss(settings_.huber_px / sigma),
                               source.rotation.data(), source.shift.data(), &inverse_depths_[observation.point]);
      used[observation.point] = true;
    }
    if (poses_free) {  // a fixed source's pose error is the star's alone
      auto* prior = new SourcePriorResidual;
      for (int i = 0; i < 3; ++i) {
        prior->centre[i] = source.centre_in_reference[i];
        for (int j = 0; j < 3; ++j) prior->rotation_to_reference[3 * i + j] = source.rotation_to_reference(i, j);
      }
      prior->inverse_rotation_sigma = 1.0 / settings_.prior_rotation_sigma_rad;
      prior->inverse_position_sigma = 1.0 / settings_.prior_position_sigma_m;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SourcePriorResidual, 6, 3, 3, 3, 3>(prior), nullptr,
                               reference_rotation_.data(), reference_shift_.data(), source.rotation.data(),
                               source.shift.data());
    }
    if (!poses_free || source.state == State::kFixed) {
      problem.SetParameterBlockConstant(source.rotation.data());
      problem.SetParameterBlockConstant(source.shift.data());
    }
  }
  if (problem.HasParameterBlock(reference_rotation_.data())) {
    // The reference's own pose error (w_r, dc_r): a rigid motion of the
    // whole star, which the features cannot see.
    auto* prior = new PosePriorResidual;
    prior->inverse_rotation_sigma = 1.0 / settings_.prior_rotation_sigma_rad;
    prior->inverse_position_sigma = 1.0 / settings_.prior_position_sigma_m;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PosePriorResidual, 6, 3, 3>(prior), nullptr,
                             reference_rotation_.data(), reference_shift_.data());
  }
  if (problem.NumResidualBlocks() == 0) return;
  for (size_t point = 0; point < rays_.size(); ++point) {
    if (!used[point]) continue;
    problem.SetParameterLowerBound(&inverse_depths_[point], 0, settings_.inverse_depth_min);
    problem.SetParameterUpperBound(&inverse_depths_[point], 0, settings_.inverse_depth_max);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = settings_.max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
}

std::vector<double> StarBundleAdjustment::errors(int index) const {
  const Source& source = sources_[index];
  std::vector<double> errors;
  errors.reserve(source.observations.size());
  for (const Observation& observation : source.observations) {
    const ObservationGeometry g =
        geometryOf(rays_[observation.point], source.rotation_to_reference, source.centre_in_reference, source.fx,
                   source.fy, source.cx, source.cy, observation.pixel);
    double pixel[2];
    const bool in_front = projectIntoSource(g.ray, g.rotation_from_reference, g.centre, g.intrinsics,
                                            source.rotation.data(), source.shift.data(),
                                            &inverse_depths_[observation.point], pixel);
    errors.push_back(in_front ? std::hypot(pixel[0] - g.pixel[0], pixel[1] - g.pixel[1])
                              : std::numeric_limits<double>::infinity());
  }
  return errors;
}

std::vector<double> StarBundleAdjustment::epipolarErrors(int index, bool tracker_pose) const {
  const Source& source = sources_[index];
  const Eigen::Vector3d rotation = tracker_pose ? Eigen::Vector3d::Zero() : source.rotation;
  const Eigen::Vector3d shift = tracker_pose ? Eigen::Vector3d::Zero() : source.shift;
  // X_src = R_sr X_ref + t_sr with R_sr = Exp(-w) R^T, t_sr = -R_sr (C + dc);
  // the essential matrix [t_sr]x R_sr maps a reference ray to the source's
  // epipolar line (normalised coordinates), scaled to pixels by K_src.
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  if (rotation.norm() > 0) turn = Eigen::AngleAxisd(-rotation.norm(), rotation.normalized()).toRotationMatrix();
  const Eigen::Matrix3d R_sr = turn * source.rotation_to_reference.transpose();
  const Eigen::Vector3d t_sr = -R_sr * (source.centre_in_reference + shift);
  Eigen::Matrix3d t_cross;
  t_cross << 0, -t_sr.z(), t_sr.y(), t_sr.z(), 0, -t_sr.x(), -t_sr.y(), t_sr.x(), 0;
  Eigen::Matrix3d K_inverse = Eigen::Matrix3d::Identity();
  K_inverse(0, 0) = 1 / source.fx;
  K_inverse(1, 1) = 1 / source.fy;
  K_inverse(0, 2) = -source.cx / source.fx;
  K_inverse(1, 2) = -source.cy / source.fy;
  const Eigen::Matrix3d fundamental = K_inverse.transpose() * t_cross * R_sr;  // pixels of the source, rays of the reference
  std::vector<double> errors;
  errors.reserve(source.observations.size());
  for (const Observation& observation : source.observations) {
    const Eigen::Vector3d line = fundamental * rays_[observation.point];
    const double norm = std::hypot(line.x(), line.y());
    const double distance = std::abs(line.dot(observation.pixel.homogeneous()));
    errors.push_back(norm > 0 ? distance / norm : std::numeric_limits<double>::infinity());
  }
  return errors;
}

void StarBundleAdjustment::keepObservationsWithin(int index, double max_px) {
  Source& source = sources_[index];
  const std::vector<double> error = errors(index);
  std::vector<Observation> kept;
  for (size_t i = 0; i < error.size(); ++i)
    if (error[i] <= max_px) kept.push_back(source.observations[i]);
  source.observations = std::move(kept);
}

void StarBundleAdjustment::setState(int index, State state) {
  Source& source = sources_[index];
  source.state = state;
  if (state == State::kFree) return;
  source.rotation.setZero();
  source.shift.setZero();
}

}  // namespace amhmvs
