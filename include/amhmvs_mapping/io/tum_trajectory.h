// Trajectories in the TUM RGB-D format: one pose per line, "stamp tx ty tz
// qx qy qz qw" (camera-to-world, the unit quaternion's w last), '#'
// comments. TUM's groundtruth.txt is read this way, and amhmvs_map writes the
// map's keyframe poses this way (keyframe_poses.txt), so that trajectory
// tools (evo, TUM's scripts) read them.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

namespace amhmvs {

using StampedPose = std::pair<double, Eigen::Isometry3d>;

// Throws InputError naming the file and line on a malformed line or a
// quaternion not of unit length (1e-3).
std::vector<StampedPose> readTumTrajectory(const std::string& path);

// `header` is written as '#' comment lines first (may be empty). Throws
// InputError when the file cannot be written.
void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses, const std::string& header);

}  // namespace amhmvs
