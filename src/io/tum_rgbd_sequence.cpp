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
#include "text_lines.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

struct Stamped {
  double stamp;
  size_t index;  // into the file's own list
};

// (stamp, path) lines of rgb.txt / depth.txt.
std::vector<std::pair<double, std::string>> readStampedPaths(const std::string& path) {
  std::vector<std::pair<double, std::string>> entries;
  for (const internal::TextLine& line : internal::readTextLines(path)) {
    internal::expectTokens(path, line, 2, "timestamp filename");
    entries.push_back({internal::numberAt(path, line, 0), line.tokens[1]});
  }
  return entries;
}

// Stamps sorted, for nearest-neighbour association.
template <typename T>
std::vector<Stamped> sortedStamps(const std::vector<std::pair<double, T>>& entries) {
  std::vector<Stamped> stamps;
  for (size_t i = 0; i < entries.size(); ++i) stamps.push_back({entries[i].first, i});
  std::sort(stamps.begin(), stamps.end(), [](const Stamped& a, const Stamped& b) { return a.stamp < b.stamp; });
  return stamps;
}

// Index of the entry nearest to `stamp` within `tolerance`, or -1.
long nearest(const std::vector<Stamped>& stamps, double stamp, double tolerance) {
  const auto after = std::lower_bound(stamps.begin(), stamps.end(), stamp,
                                      [](const Stamped& s, double t) { return s.stamp < t; });
  long best = -1;
  double best_gap = tolerance;
  for (auto it : {after, after - (after == stamps.begin() ? 0 : 1)}) {
    if (it == stamps.end()) continue;
    const double gap = std::abs(it->stamp - stamp);
    if (gap <= best_gap) best_gap = gap, best = static_cast<long>(it->index);
  }
  return best;
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
  const std::vector<Stamped> pose_stamps = sortedStamps(poses), depth_stamps = sortedStamps(depths);
  const Intrinsics k = options.color_intrinsics.set() ? options.color_intrinsics : defaultTumIntrinsics(dir);

  PosedSequence sequence;
  sequence.layout = "tum";
  sequence.dir = dir;
  double last_stamp = -INFINITY;
  for (size_t i = 0; i < colors.size(); ++i) {
    const double stamp = colors[i].first;
    const long pose = nearest(pose_stamps, stamp, options.tum_max_time_difference_s);
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
    const long depth = nearest(depth_stamps, stamp, options.tum_max_time_difference_s);
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
