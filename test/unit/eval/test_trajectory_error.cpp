// The trajectory error report: exact on constructed errors, the alignment
// removes a rigid motion of the whole estimate, the misalignment agrees with
// a brute-force projection, and bad input is named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/eval/trajectory_error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr double kDegree = M_PI / 180;

PinholeCamera camera() { return test::centredCamera(320, 240, 500); }

Eigen::Isometry3d rotationAboutY(double radians) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return pose;
}

// 20 frames 6 cm apart along x, turning 1 degree each: every frame a keyframe.
std::vector<Eigen::Isometry3d> walk() {
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 20; ++i) {
    Eigen::Isometry3d pose = rotationAboutY(i * kDegree);
    pose.translation() = Eigen::Vector3d(0.06 * i, 0.01 * std::sin(i), 0);
    poses.push_back(pose);
  }
  return poses;
}

// A wall 2 m ahead of every frame.
ImageF wall(size_t) { return ImageF(camera().width, camera().height, 1, 2.0f); }

TEST(TrajectoryError, IdenticalTrajectoriesHaveNone) {
  const std::vector<Eigen::Isometry3d> poses = walk();
  const TrajectoryError error = trajectoryError(poses, poses, camera(), wall);
  EXPECT_EQ(error.poses, 20u);
  EXPECT_EQ(error.keyframes.size(), 20u);
  EXPECT_EQ(error.keyframe_pairs, 19u);
  EXPECT_EQ(error.misalignment_pairs, 19u);
  EXPECT_LT(error.ate_max_m, 1e-12);
  EXPECT_LT(error.rpe_translation_max_m, 1e-12);
  EXPECT_LT(error.rpe_rotation_max_deg, 1e-5);
  EXPECT_LT(error.misalignment_max_px, 1e-9);
}

TEST(TrajectoryError, ARigidMotionOfTheWholeEstimateIsAlignedAway) {
  const std::vector<Eigen::Isometry3d> reference = walk();
  Eigen::Isometry3d motion = rotationAboutY(30 * kDegree);
  motion.translation() = Eigen::Vector3d(1, -2, 0.5);
  std::vector<Eigen::Isometry3d> estimated;
  for (const Eigen::Isometry3d& pose : reference) estimated.push_back(motion * pose);
  const TrajectoryError error = trajectoryError(estimated, reference, camera(), wall);
  EXPECT_LT(error.ate_max_m, 1e-9);
  EXPECT_LT(error.rpe_translation_max_m, 1e-9);
  EXPECT_LT(error.misalignment_max_px, 1e-6);
}

TEST(TrajectoryError, OneFramesCentreOffIsItsAbsoluteError) {
  const std::vector<Eigen::Isometry3d> reference = walk();
  std::vector<Eigen::Isometry3d> estimated = reference;
  estimated[10].translation() += Eigen::Vector3d(0, 0, 0.01);
  const TrajectoryError error = trajectoryError(estimated, reference, camera(), wall);
  // The alignment moves the rest by about 1/20 of it.
  EXPECT_GT(error.ate_max_m, 0.009);
  EXPECT_LT(error.ate_max_m, 0.01);
  EXPECT_NEAR(error.rpe_translation_max_m, 0.01, 1e-9);  // both pairs of frame 10
}

TEST(TrajectoryError, ALastKeyframeTurnedIsItsRotationAndPixels) {
  const std::vector<Eigen::Isometry3d> reference = walk();
  std::vector<Eigen::Isometry3d> estimated = reference;
  const double turn = 0.5 * kDegree;
  estimated.back() = estimated.back() * rotationAboutY(turn);  // about its own centre
  const TrajectoryError error = trajectoryError(estimated, reference, camera(), wall);
  EXPECT_LT(error.ate_max_m, 1e-12);  // the centres are exact
  EXPECT_NEAR(error.rpe_rotation_max_deg, 0.5, 1e-9);
  EXPECT_NEAR(error.rpe_rotation_rmse_deg, 0.5 / std::sqrt(19.0), 1e-9);
  EXPECT_LT(error.rpe_translation_max_m, 1e-12);
  // Brute force: the last pair's sampled wall pixels through both poses.
  const PinholeCamera c = camera();
  const Eigen::Isometry3d a = reference[18], b = reference[19], b_estimated = estimated[19];
  std::vector<double> distances;
  for (int y = 4; y < c.height; y += 8) {
    for (int x = 4; x < c.width; x += 8) {
      const Eigen::Vector3d world = a * c.backproject(x, y, 2.0);
      distances.push_back((c.project(b.inverse() * world) - c.project(b_estimated.inverse() * world)).norm());
    }
  }
  EXPECT_NEAR(error.misalignment_max_px, medianOf(distances), 1e-9);
  EXPECT_GT(error.misalignment_max_px, c.fx * std::tan(turn));  // f tan(turn) at the centre, more off it
  EXPECT_LT(error.misalignment_max_px, 1.1 * c.fx * std::tan(turn));
  EXPECT_LT(error.misalignment_median_px, 1e-9);  // the other 18 pairs are exact
}

TEST(TrajectoryError, PairsWithoutDepthAreLeftOutOfTheMisalignment) {
  const std::vector<Eigen::Isometry3d> poses = walk();
  const TrajectoryError error =
      trajectoryError(poses, poses, camera(), [](size_t i) { return i % 2 ? ImageF() : wall(i); });
  EXPECT_EQ(error.keyframe_pairs, 19u);
  EXPECT_EQ(error.misalignment_pairs, 10u);  // pairs starting at frames 0, 2, ..., 18
  const std::string json = trajectoryErrorJson(trajectoryError(poses, poses, camera(), {}));
  EXPECT_NE(json.find("\"misalignment_median_px\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"keyframe_pairs\": 19"), std::string::npos) << json;
}

TEST(TrajectoryError, BadInputIsAClearError) {
  const std::vector<Eigen::Isometry3d> poses = walk();
  EXPECT_INPUT_ERROR(trajectoryError({poses.begin(), poses.begin() + 5}, poses, camera(), wall), "5 estimated",
                     "20 reference");
  EXPECT_INPUT_ERROR(trajectoryError({poses[0]}, {poses[0]}, camera(), wall), "at least 2", "poses");
  TrajectoryErrorOptions options;
  options.pixel_stride = 0;
  EXPECT_INPUT_ERROR(trajectoryError(poses, poses, camera(), wall, options), "pixel_stride", "at least 1");
}

}  // namespace
}  // namespace amhmvs
