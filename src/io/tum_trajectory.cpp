#include "amhmvs_mapping/io/tum_trajectory.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "text_lines.h"

namespace amhmvs {

std::vector<StampedPose> readTumTrajectory(const std::string& path) {
  std::vector<StampedPose> poses;
  for (const internal::TextLine& line : internal::readTextLines(path)) {
    internal::expectTokens(path, line, 8, "timestamp tx ty tz qx qy qz qw");
    double v[8];
    for (size_t i = 0; i < 8; ++i) v[i] = internal::numberAt(path, line, i);
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1) > 1e-3) {
      internal::failAt(path, line.number, "quaternion (qx qy qz qw) is not of unit length");
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = q.normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    poses.push_back({v[0], pose});
  }
  return poses;
}

void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses, const std::string& header) {
  std::string text;
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) text += "# " + line + "\n";
  char row[256];
  for (const StampedPose& stamped : poses) {
    const Eigen::Vector3d& t = stamped.second.translation();
    const Eigen::Quaterniond q(stamped.second.linear());
    // 17 significant digits: the doubles come back as they were written.
    std::snprintf(row, sizeof(row), "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", stamped.first, t.x(), t.y(),
                  t.z(), q.x(), q.y(), q.z(), q.w());
    text += row;
  }
  writeFileAtomically(path, text, "trajectory");
}

}  // namespace amhmvs
