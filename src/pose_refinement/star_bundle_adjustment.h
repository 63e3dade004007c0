// The bundle adjustment of the pose refinement (Ceres): one reference view
// and its sources, each source linked to the reference only (a star).
//
// Unknowns: per source, a correction of its pose relative to the reference
// (rotation vector w about the source's own centre, shift dc of that centre
// in the reference frame); per reference feature, its inverse depth rho.
// A feature with reference ray r = K_ref^-1 (u, v, 1) lies at X = r / rho
// in the reference frame; with the tracker's relative pose (R: source to
// reference rotation, C: source centre in the reference frame) the source
// sees it at
//     X_src ~ Exp(-w) R^T (r - rho (C + dc))      (homogeneous: times rho)
// Residuals: the reprojection error / feature_sigma under a Huber loss
// (robust beyond the inlier threshold), and the tracker's noise as a prior
// on every keyframe's own pose error (per axis, sigma_rotation and
// sigma_position): the reference's (w_r, dc_r, a rigid motion of the whole
// star that the features cannot see, solved and not used) and each source's
// (w_r, dc_r and w_r x C carried over, plus R w and dc). So the scale of the
// translations, which the features cannot see either, is the one that fits
// all the keyframes' tracker poses best, the reference's included.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs {

struct StarAdjustmentSettings {
  double feature_sigma_px = 0.5;
  double huber_px = 1.5;                // reprojection errors beyond this weigh linearly
  double prior_position_sigma_m = 0.01;
  double prior_rotation_sigma_rad = 0.005;
  int max_iterations = 30;
  double inverse_depth_min = 0, inverse_depth_max = 0;  // bounds of rho
};

class StarBundleAdjustment {
 public:
  struct Observation {
    int point = 0;            // index into the reference rays
    Eigen::Vector2d pixel;    // in the source
    double sigma_px = 0;      // its position noise; 0: settings' feature_sigma_px
  };

  // `rays`: the reference features' rays K_ref^-1 (u, v, 1); their inverse
  // depths start at `initial_inverse_depth`.
  StarBundleAdjustment(std::vector<Eigen::Vector3d> rays, double initial_inverse_depth,
                       const StarAdjustmentSettings& settings);

  // A source with the tracker's relative pose; returns its index. Free.
  int addSource(const PinholeCamera& intrinsics, const Eigen::Matrix3d& rotation_to_reference,
                const Eigen::Vector3d& centre_in_reference, std::vector<Observation> observations);

  // Solves the inverse depths of the points that the free and fixed sources
  // see with every pose held (poses_free false), or with the free sources'
  // corrections too.
  void solve(bool poses_free);

  // Reprojection error in pixels of each observation of a source, now.
  std::vector<double> errors(int source) const;
  // Distance in pixels of each observation of a source from the epipolar
  // line of its reference feature: with the pose now, or with the tracker's.
  // The error that stereo suffers, whatever the points' depths.
  std::vector<double> epipolarErrors(int source, bool tracker_pose) const;
  // Keeps the observations of a source with an error at most `max_px`.
  void keepObservationsWithin(int source, double max_px);
  size_t observationCount(int source) const { return sources_[source].observations.size(); }
  int sourceCount() const { return static_cast<int>(sources_.size()); }

  // Both keep the tracker's pose (the correction is zeroed): a fixed source
  // still constrains the points, an inactive one takes no part in later
  // solves.
  enum class State { kFree, kFixed, kInactive };
  void setState(int source, State state);
  State state(int source) const { return sources_[source].state; }

  const Eigen::Vector3d& rotationCorrection(int source) const { return sources_[source].rotation; }
  const Eigen::Vector3d& centreCorrection(int source) const { return sources_[source].shift; }

 private:
  struct Source {
    double fx, fy, cx, cy;
    Eigen::Matrix3d rotation_to_reference;
    Eigen::Vector3d centre_in_reference;
    std::vector<Observation> observations;
    State state = State::kFree;
    Eigen::Vector3d rotation = Eigen::Vector3d::Zero();  // w
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();     // dc
  };

  Eigen::Vector3d reference_rotation_ = Eigen::Vector3d::Zero();  // w_r
  Eigen::Vector3d reference_shift_ = Eigen::Vector3d::Zero();     // dc_r
  std::vector<Eigen::Vector3d> rays_;
  std::vector<double> inverse_depths_;
  std::vector<Source> sources_;
  StarAdjustmentSettings settings_;
};

}  // namespace amhmvs
