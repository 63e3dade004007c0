#include "amhmvs_mapping/eval/pose_alignment.h"

#include <string>

#include <Eigen/SVD>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

PoseAlignment alignPoses(const std::vector<Eigen::Isometry3d>& from, const std::vector<Eigen::Isometry3d>& to,
                         AlignmentKind kind) {
  if (from.size() != to.size()) {
    throw InputError("pose alignment: " + std::to_string(from.size()) + " poses to align with " +
                     std::to_string(to.size()));
  }
  if (from.size() < 2) throw InputError("pose alignment: at least 2 poses are needed");
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < from.size(); ++i) {
    sum += to[i].linear() * from[i].linear().transpose();
    mean_from += from[i].translation() / from.size();
    mean_to += to[i].translation() / to.size();
  }
  // The rotation nearest to the sum (its polar factor, determinant +1).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  PoseAlignment alignment;
  alignment.rotation = svd.matrixU() * fix * svd.matrixV().transpose();
  if (kind == AlignmentKind::kRigid) {
    alignment.translation = mean_to - alignment.rotation * mean_from;
    return alignment;
  }
  double along = 0, spread = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d a = alignment.rotation * (from[i].translation() - mean_from);
    along += a.dot(to[i].translation() - mean_to);
    spread += a.squaredNorm();
  }
  if (!(spread > 0)) throw InputError("pose alignment: the cameras' centres all coincide");
  alignment.scale = along / spread;
  alignment.translation = mean_to - alignment.scale * alignment.rotation * mean_from;
  return alignment;
}

}  // namespace amhmvs
