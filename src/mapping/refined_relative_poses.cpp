#include "amhmvs_mapping/mapping/refined_relative_poses.h"

#include <Eigen/SVD>

namespace amhmvs {
namespace {

Eigen::Isometry3d worldToCamera(const PinholeCamera& camera) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = camera.R;
  pose.translation() = camera.t;
  return pose;
}

}  // namespace

void RefinedRelativePoses::record(int64_t reference, const PinholeCamera& reference_camera, int64_t source,
                                  const PinholeCamera& refined_source_camera) {
  poses_[{reference, source}] = worldToCamera(refined_source_camera) * worldToCamera(reference_camera).inverse();
}

void RefinedRelativePoses::drop(int64_t reference, int64_t source) { poses_.erase({reference, source}); }

bool RefinedRelativePoses::place(int64_t reference, const PinholeCamera& reference_camera, int64_t view,
                                 PinholeCamera* camera) const {
  Eigen::Isometry3d view_from_reference;
  const auto forward = poses_.find({reference, view});
  if (forward != poses_.end()) {
    view_from_reference = forward->second;
  } else {
    const auto backward = poses_.find({view, reference});
    if (backward == poses_.end()) return false;
    view_from_reference = backward->second.inverse();
  }
  const Eigen::Isometry3d view_from_world = view_from_reference * worldToCamera(reference_camera);
  // The nearest rotation: a tracker's rotation a little off orthonormal
  // (7-Scenes': |R R^T - I| about 4e-4) comes out further off through the
  // inverse above, past what fusion accepts as rigid (1e-3).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(view_from_world.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  camera->R = svd.matrixU() * svd.matrixV().transpose();
  camera->t = view_from_world.translation();
  return true;
}

void RefinedRelativePoses::forget(int64_t id) {
  for (auto pair = poses_.begin(); pair != poses_.end();) {
    pair = pair->first.first == id || pair->first.second == id ? poses_.erase(pair) : std::next(pair);
  }
}

}  // namespace amhmvs
