// alignPoses (eval/pose_alignment.h): a known similarity between two sets of
// poses (centres nearly on a line) is found exactly, and so is a rigid
// motion, which keeps the scale at 1 where the poses differ in scale too;
// bad inputs are refused by name.
#include <gtest/gtest.h>

#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/pose_alignment.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

TEST(PoseAlignment, FindsTheSimilarityBetweenTwoTrajectories) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const double scale = 1.007;
  const Eigen::Vector3d shift(0.3, -1.2, 2.0);
  std::vector<Eigen::Isometry3d> from, to;
  for (int i = 0; i < 6; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.1 * i, 0.02 * i * i, 0);  // nearly a line: orientations fix the roll
    from.push_back(pose);
    Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
    moved.linear() = turn * pose.linear();
    moved.translation() = scale * turn * pose.translation() + shift;
    to.push_back(moved);
  }
  const PoseAlignment alignment = alignPoses(from, to);
  EXPECT_NEAR(alignment.scale, scale, 1e-9);
  EXPECT_LT((alignment.rotation - turn).norm(), 1e-9);
  const Eigen::Vector3f point(1.0f, 2.0f, 3.0f);
  const Eigen::Vector3d want = scale * turn * point.cast<double>() + shift;
  EXPECT_LT((alignment.apply(point).cast<double>() - want).norm(), 1e-5);
  // The same poses: the identity.
  const PoseAlignment same = alignPoses(from, from);
  EXPECT_LT((same.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-9);
  EXPECT_NEAR(same.scale, 1.0, 1e-12);
  EXPECT_LT(same.translation.norm(), 1e-12);
}

TEST(PoseAlignment, RigidAlignmentKeepsTheScale) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(-0.7, Eigen::Vector3d(0.2, 1, -0.4).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(-0.5, 0.4, 1.5);
  std::vector<Eigen::Isometry3d> from, rigid, scaled;
  for (int i = 0; i < 5; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(0.15 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.2 * i, -0.05 * i, 0.01 * i * i);
    from.push_back(pose);
    Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
    moved.linear() = turn * pose.linear();
    moved.translation() = turn * pose.translation() + shift;
    rigid.push_back(moved);
    moved.translation() = 1.1 * turn * pose.translation() + shift;  // scale 1.1 about the world origin
    scaled.push_back(moved);
  }
  const PoseAlignment exact = alignPoses(from, rigid, AlignmentKind::kRigid);
  EXPECT_EQ(exact.scale, 1.0);
  EXPECT_LT((exact.rotation - turn).norm(), 1e-9);
  EXPECT_LT((exact.translation - shift).norm(), 1e-9);
  // Scaled centres: the rigid fit keeps scale 1, rotates as the orientations
  // say and puts the centres' means together (the least-squares translation).
  const PoseAlignment kept = alignPoses(from, scaled, AlignmentKind::kRigid);
  EXPECT_EQ(kept.scale, 1.0);
  EXPECT_LT((kept.rotation - turn).norm(), 1e-9);
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < from.size(); ++i) {
    mean_from += from[i].translation() / from.size();
    mean_to += scaled[i].translation() / scaled.size();
  }
  EXPECT_LT((turn * mean_from + kept.translation - mean_to).norm(), 1e-9);
  EXPECT_NEAR(alignPoses(from, scaled).scale, 1.1, 1e-9);  // the similarity sees the scale
}

TEST(PoseAlignment, BadInputIsRefused) {
  const std::vector<Eigen::Isometry3d> two(2, Eigen::Isometry3d::Identity()), one(1, Eigen::Isometry3d::Identity());
  EXPECT_INPUT_ERROR(alignPoses(two, one), "pose alignment", "2 poses to align with 1");
  EXPECT_INPUT_ERROR(alignPoses(one, one), "pose alignment", "at least 2 poses");
  EXPECT_INPUT_ERROR(alignPoses(two, two), "pose alignment", "centres all coincide");
}

}  // namespace
}  // namespace amhmvs
