// The similarity (or rigid motion) that best carries one set of camera poses
// onto another, for reports: a map built behind a tracker is in the tracker's frame, whose
// overall scale and orientation drift no online mapper can see; judging it
// after this alignment separates that gauge from the map's own shape (as
// trajectory benchmarks align before the absolute trajectory error). A
// tracker with metric depth (RGB-D) has no scale to drift: its map is judged
// after the rigid motion (AlignmentKind::kRigid) instead.
#pragma once

#include <vector>

#include <Eigen/Geometry>

namespace amhmvs {

struct PoseAlignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // x_to = scale rotation x_from + translation
  double scale = 1;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3f apply(const Eigen::Vector3f& point) const {
    return (scale * rotation * point.cast<double>() + translation).cast<float>();
  }
};

enum class AlignmentKind { kSimilarity, kRigid };

// `from` and `to`: camera-to-world poses of the same cameras, in order. The
// rotation is the chordal mean of the cameras' rotations to_i from_i^T
// (orientations fix it even when the centres lie on a line); scale (1 for
// kRigid) and translation are then the least-squares fit of the centres.
// Exact for poses that differ by one such motion. Throws InputError for sizes
// that differ, fewer than 2 poses or (kSimilarity) centres that all coincide.
PoseAlignment alignPoses(const std::vector<Eigen::Isometry3d>& from, const std::vector<Eigen::Isometry3d>& to,
                         AlignmentKind kind = AlignmentKind::kSimilarity);

}  // namespace amhmvs
