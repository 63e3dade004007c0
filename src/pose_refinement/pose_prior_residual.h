// A keyframe's pose correction (w: rotation vector, dc: shift of its centre)
// in units of the tracker's noise: the prior of the star and keyframe bundle
// adjustments and of the keyframe pose graph (Ceres autodiff functor, 6
// residuals); the corrected rotation, Exp(w) R; and the solve of the
// keyframe graph and bundle adjustment, sparse where this Ceres can.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace amhmvs {

// Exp(w) R: a corrected camera-to-world rotation (about the camera's centre,
// world axes).
template <typename T>
Eigen::Matrix<T, 3, 3> correctedRotation(const T* w, const Eigen::Matrix3d& rotation) {
  Eigen::Matrix<T, 3, 3> turn;
  ceres::AngleAxisToRotationMatrix(w, turn.data());  // column-major, as Eigen's default
  return turn * rotation.cast<T>();
}

// A camera-to-world pose with a solved correction applied.
inline Eigen::Isometry3d correctedPose(const Eigen::Isometry3d& pose, const double* w, const double* dc) {
  const Eigen::Vector3d turn(w), shift(dc);
  Eigen::Isometry3d corrected = pose;
  if (turn.norm() > 0)
    corrected.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * pose.linear();
  corrected.translation() += shift;
  return corrected;
}

struct PosePriorResidual {
  double inverse_rotation_sigma = 1, inverse_position_sigma = 1;

  template <typename T>
  bool operator()(const T* w, const T* dc, T* residual) const {
    for (int i = 0; i < 3; ++i) {
      residual[i] = w[i] * T(inverse_rotation_sigma);
      residual[3 + i] = dc[i] * T(inverse_position_sigma);
    }
    return true;
  }
};

// A prior on every correction (a map of key -> {double w[3], dc[3]}).
template <typename Corrections>
void addPosePriors(double rotation_sigma_rad, double position_sigma_m, Corrections* corrections,
                   ceres::Problem* problem) {
  for (auto& entry : *corrections) {
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PosePriorResidual, 6, 3, 3>(
                                  new PosePriorResidual{1 / rotation_sigma_rad, 1 / position_sigma_m}),
                              nullptr, entry.second.w, entry.second.dc);
  }
}

// One thread (the mapper's); `dense` where this Ceres has no sparse library.
inline bool solveProblem(ceres::Problem* problem, int max_iterations, ceres::LinearSolverType sparse,
                         ceres::LinearSolverType dense) {
  ceres::Solver::Options options;
  options.max_num_iterations = max_iterations;
  options.linear_solver_type = sparse;
  std::string unusable;
  if (!options.IsValid(&unusable)) options.linear_solver_type = dense;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  return summary.IsSolutionUsable();
}

}  // namespace amhmvs
