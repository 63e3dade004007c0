// The TUM RGB-D layout: rgb.txt and depth.txt ("stamp path" lines),
// groundtruth.txt ("stamp tx ty tz qx qy qz qw", camera-to-world), '#'
// comments. Colour frames are paired with the pose and depth of the nearest
// stamp within the tolerance; colour frames without a pose are left out.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "stamp_association.h"
#include "text_lines.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

// (stamp, path) lines of rgb.txt / depth.txt.
std::vector<std::pair<double, std::string>> readStampedPaths(const std::string& path) {
  std::vector<std::pair<double, std::string>> entries;
  for (const internal::TextLine& line : internal::readTextLines(path)) {
    internal::expectTokens(path, line, 2, "timestamp filename");
    entries.push_back({internal::numberAt(path, line, 0), line.tokens[1]});
  }
  return entries;
}

Intrinsics defaultTumIntrinsics(const std::string& dir) {
  const std::string name = fs::absolute(fs::path(dir)).lexically_normal().string();
  for (const char* camera : {"freiburg1", "freiburg2", "freiburg3"}) {
    if (name.find(camera) != std::string::npos) return parseIntrinsics(camera);
  }
  return parseIntrinsics("ros");
}

}  // namespace

PosedSequence readTumSequence(const std::string& dir, const PosedSequenceOptions& options) {
  const auto colors = readStampedPaths(dir + "/rgb.txt");
  const auto poses = readTumTrajectory(dir + "/groundtruth.txt");
  std::vector<std::pair<double, std::string>> depths;
  if (fs::exists(dir + "/depth.txt")) depths = readStampedPaths(dir + "/depth.txt");
  const std::vector<internal::Stamped> pose_stamps = internal::sortedStamps(poses),
                                      depth_stamps = internal::sortedStamps(depths);
  const Intrinsics k = options.color_intrinsics.set() ? options.color_intrinsics : defaultTumIntrinsics(dir);

  PosedSequence sequence;
  sequence.layout = "tum";
  sequence.dir = dir;
  double last_stamp = -INFINITY;
  for (size_t i = 0; i < colors.size(); ++i) {
    const double stamp = colors[i].first;
    const long pose = internal::nearest(pose_stamps, stamp, options.tum_max_time_difference_s);
    if (pose < 0) continue;
    if (stamp < last_stamp) {
      throw InputError(dir + "/rgb.txt: stamps must not decrease (" + std::to_string(stamp) + " after " +
                       std::to_string(last_stamp) + ")");
    }
    last_stamp = stamp;
    PosedFrame frame;
    frame.id = static_cast<int64_t>(i);
    frame.name = fs::path(colors[i].second).filename().string();
    frame.stamp = stamp;
    frame.image_path = dir + "/" + colors[i].second;
    frame.camera = cameraOfImage(k, frame.image_path, poses[pose].second, dir + "/groundtruth.txt");
    const long depth = internal::nearest(depth_stamps, stamp, options.tum_max_time_difference_s);
    if (depth >= 0) {
      frame.ground_truth.path = dir + "/" + depths[depth].second;
      frame.ground_truth.metres_per_unit = 1.0 / options.tum_depth_units_per_metre;
    }
    sequence.frames.push_back(std::move(frame));
  }
  if (sequence.frames.empty()) {
    throw InputError(dir + ": no colour frame of rgb.txt has a pose in groundtruth.txt within " +
                     std::to_string(options.tum_max_time_difference_s) + " s");
  }
  return sequence;
}

}  // namespace amhmvs
