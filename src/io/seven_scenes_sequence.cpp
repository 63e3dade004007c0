// The 7-Scenes / tsdf-fusion layout: frame-NNNNNN.color.(jpg|png; ppm|pgm
// where converted for builds without OpenCV),
// frame-NNNNNN.pose.txt (4x4 camera-to-world of the depth camera, metres),
// frame-NNNNNN.depth.png|pgm (uint16 millimetres, 0 and 65535 invalid) and
// camera-intrinsics.txt (the depth camera's K).
#include <algorithm>
#include <filesystem>
#include <regex>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/posed_sequence.h"
#include "text_lines.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

Intrinsics intrinsicsFromMatrix(const std::vector<std::vector<double>>& k, const std::string& path) {
  if (k[0][1] != 0 || k[1][0] != 0 || k[2][0] != 0 || k[2][1] != 0 || k[2][2] != 1 ||
      !(k[0][0] > 0) || !(k[1][1] > 0)) {
    throw InputError(path + ": expected a pinhole K (fx 0 cx / 0 fy cy / 0 0 1, fx, fy > 0)");
  }
  return {k[0][0], k[1][1], k[0][2], k[1][2]};
}

Eigen::Isometry3d readPoseFile(const std::string& path) {
  const std::vector<std::vector<double>> m = internal::readMatrixFile(path, 4, 4);
  if (m[3][0] != 0 || m[3][1] != 0 || m[3][2] != 0 || m[3][3] != 1) {
    throw InputError(path + ": line 4: the bottom row must be 0 0 0 1");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) pose.matrix()(r, c) = m[r][c];
  }
  return pose;
}

}  // namespace

PosedSequence readSevenScenesSequence(const std::string& dir, const PosedSequenceOptions& options) {
  if (!fs::is_directory(dir)) throw InputError(dir + ": sequence folder does not exist");
  const std::string intrinsics_path = dir + "/camera-intrinsics.txt";
  const Intrinsics depth_intrinsics =
      intrinsicsFromMatrix(internal::readMatrixFile(intrinsics_path, 3, 3), intrinsics_path);
  const Intrinsics color_intrinsics = options.color_intrinsics.set() ? options.color_intrinsics : depth_intrinsics;

  // frame number -> colour file name
  // PPM/PGM too: builds without OpenCV read sequences converted to them.
  static const std::regex kColor(R"(frame-(\d+)\.color\.(jpg|jpeg|png|ppm|pgm))", std::regex::icase);
  std::vector<std::pair<long long, std::string>> colors;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    std::smatch match;
    if (std::regex_match(name, match, kColor)) colors.push_back({std::stoll(match[1].str()), name});
  }
  std::sort(colors.begin(), colors.end());
  for (size_t i = 1; i < colors.size(); ++i) {
    if (colors[i].first == colors[i - 1].first) {
      throw InputError(dir + ": two colour images for frame " + std::to_string(colors[i].first) + ": " +
                       colors[i - 1].second + " and " + colors[i].second);
    }
  }
  if (colors.empty()) throw InputError(dir + ": no frame-NNNNNN.color.jpg|png|ppm|pgm images");

  PosedSequence sequence;
  sequence.layout = "7scenes";
  sequence.dir = dir;
  for (const auto& [number, name] : colors) {
    const std::string prefix = dir + "/" + name.substr(0, name.find(".color."));
    PosedFrame frame;
    frame.id = number;
    frame.name = name;
    frame.stamp = static_cast<double>(number) / options.seven_scenes_frame_rate_hz;
    frame.image_path = dir + "/" + name;
    const std::string pose_path = prefix + ".pose.txt";
    if (!fs::exists(pose_path)) throw InputError(pose_path + ": missing pose of " + name);
    const Eigen::Isometry3d depth_to_world = readPoseFile(pose_path);
    // The colour camera: same orientation, centre moved by the offset in the depth frame.
    const Eigen::Isometry3d color_to_world = depth_to_world * Eigen::Translation3d(options.color_offset);
    frame.camera = cameraOfImage(color_intrinsics, frame.image_path, color_to_world, pose_path);
    std::string depth_path = prefix + ".depth.png";
    if (!fs::exists(depth_path)) depth_path = prefix + ".depth.pgm";  // converted, 16-bit
    if (fs::exists(depth_path)) {
      GroundTruthDepthSource& truth = frame.ground_truth;
      truth.path = depth_path;
      truth.metres_per_unit = 0.001;
      truth.invalid_value = 65535;
      truth.registered = false;
      truth.depth_camera = cameraOfImage(depth_intrinsics, depth_path, depth_to_world, pose_path);
    }
    sequence.frames.push_back(std::move(frame));
  }
  return sequence;
}

}  // namespace amhmvs
