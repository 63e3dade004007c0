// TUM trajectories: what amhmvs_map writes (keyframe_poses.txt) reads back
// as written, and malformed lines are named.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

TEST(TumTrajectory, ReadsBackWhatItWrote) {
  test::TempDir dir;
  std::vector<StampedPose> written;
  for (int k = 0; k < 5; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(0.3 * k + 0.1, Eigen::Vector3d(1, -2, 0.5 * k).normalized()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(1.0 / 3 * k, -2.25, 1e-7 * k);
    written.push_back({1234567890.123456 + 0.1 * k, pose});
  }
  const std::string path = dir.file("poses.txt");
  writeTumTrajectory(path, written, "first comment\nstamp tx ty tz qx qy qz qw");
  std::ifstream in(path);
  std::string first_line;
  std::getline(in, first_line);
  EXPECT_EQ(first_line, "# first comment");
  const std::vector<StampedPose> read = readTumTrajectory(path);
  ASSERT_EQ(read.size(), written.size());
  for (size_t k = 0; k < read.size(); ++k) {
    EXPECT_EQ(read[k].first, written[k].first) << k;
    EXPECT_EQ(read[k].second.translation(), written[k].second.translation()) << k;
    EXPECT_LT((read[k].second.linear() - written[k].second.linear()).cwiseAbs().maxCoeff(), 1e-15) << k;
  }
}

TEST(TumTrajectory, NamesTheBadLine) {
  test::TempDir dir;
  EXPECT_INPUT_ERROR(readTumTrajectory(dir.write("a.txt", "# x\n1.0 0 0 0 0 0 0\n")), "a.txt: line 2", "8 fields");
  EXPECT_INPUT_ERROR(readTumTrajectory(dir.write("b.txt", "1.0 0 0 0 0 0 0 2\n")), "b.txt: line 1", "unit length");
  EXPECT_INPUT_ERROR(readTumTrajectory(dir.write("c.txt", "1.0 0 0 zero 0 0 0 1\n")), "c.txt: line 1", "zero");
  EXPECT_INPUT_ERROR(writeTumTrajectory(dir.file("missing/d.txt"), {}, ""), "missing/d.txt", "cannot open the trajectory for writing");
}

}  // namespace
}  // namespace amhmvs
