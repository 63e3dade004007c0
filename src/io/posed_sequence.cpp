// Layout detection, named intrinsics, and the MVSNet / COLMAP layouts as
// posed sequences (the RGB-D layouts have files of their own).
#include "amhmvs_mapping/io/posed_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/colmap_model.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "file_util.h"
#include "stamp_association.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

bool anyFileEndsWith(const std::string& dir, const std::string& suffix) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      return true;
    }
  }
  return false;
}

// Frames of a Scene (MVSNet, COLMAP) in id order, stamped index * period.
PosedSequence fromScene(const Scene& scene, const std::string& layout, const std::string& dir,
                        double frame_period_s) {
  PosedSequence sequence;
  sequence.layout = layout;
  sequence.dir = dir;
  for (const SceneView& view : scene.views) {
    PosedFrame frame;
    frame.id = view.id;
    frame.name = view.name;
    frame.stamp = static_cast<double>(sequence.frames.size()) * frame_period_s;
    frame.image_path = view.image_path;
    frame.camera = view.camera;
    if (std::isfinite(view.depth_min) && std::isfinite(view.depth_max)) {
      frame.depth_min = view.depth_min;
      frame.depth_max = view.depth_max;
    }
    sequence.frames.push_back(std::move(frame));
  }
  if (sequence.frames.empty()) throw InputError(dir + ": the sequence has no frames");
  return sequence;
}

}  // namespace

PinholeCamera cameraOfImage(const Intrinsics& intrinsics, const std::string& image_path,
                            const Eigen::Isometry3d& camera_to_world, const std::string& pose_origin) {
  PinholeCamera camera;
  if (!readImageSize(image_path, &camera.width, &camera.height)) {
    const ImageU8 image = readImage(image_path);
    camera.width = image.width;
    camera.height = image.height;
  }
  camera.fx = intrinsics.fx;
  camera.fy = intrinsics.fy;
  camera.cx = intrinsics.cx;
  camera.cy = intrinsics.cy;
  setCameraToWorld(camera_to_world, &camera);
  const std::string problem = camera.validate();
  if (!problem.empty()) throw InputError(pose_origin + ": " + problem);
  return camera;
}

Intrinsics parseIntrinsics(const std::string& text) {
  if (text == "freiburg1") return {517.3, 516.5, 318.6, 255.3};
  if (text == "freiburg2") return {520.9, 521.0, 325.1, 249.7};
  if (text == "freiburg3") return {535.4, 539.2, 320.1, 247.6};
  if (text == "ros") return {525.0, 525.0, 319.5, 239.5};
  if (text == "fitted7scenes") return {528.0, 528.0, 316.0, 238.0};
  std::vector<double> values;
  std::istringstream in(text);
  std::string item;
  bool numbers = true;
  while (std::getline(in, item, ',')) {
    double v = 0;
    numbers = numbers && internal::parseDouble(item, &v);
    values.push_back(v);
  }
  if (!numbers || values.size() != 4 || !(values[0] > 0) || !(values[1] > 0)) {
    throw InputError("intrinsics '" + text +
                     "': expected freiburg1, freiburg2, freiburg3, ros, fitted7scenes or "
                     "fx,fy,cx,cy with fx, fy > 0");
  }
  return {values[0], values[1], values[2], values[3]};
}

std::string PosedSequenceOptions::validate() const {
  std::string problems;
  auto check = [&problems](bool ok, const std::string& what) {
    if (!ok) problems += what + "\n";
  };
  check(!color_intrinsics.set() || (color_intrinsics.fy > 0 && std::isfinite(color_intrinsics.fx) &&
                                    std::isfinite(color_intrinsics.cx) &&
                                    std::isfinite(color_intrinsics.cy)),
        "color_intrinsics: fx, fy must be > 0 and all finite");
  check(color_offset.allFinite(), "color_offset: must be finite");
  check(seven_scenes_frame_rate_hz > 0 && std::isfinite(seven_scenes_frame_rate_hz),
        "seven_scenes_frame_rate_hz: must be > 0");
  check(tum_max_time_difference_s > 0 && std::isfinite(tum_max_time_difference_s),
        "tum_max_time_difference_s: must be > 0");
  check(tum_depth_units_per_metre > 0 && std::isfinite(tum_depth_units_per_metre),
        "tum_depth_units_per_metre: must be > 0");
  check(frame_period_s > 0 && std::isfinite(frame_period_s), "frame_period_s: must be > 0");
  check(colmap_min_points >= 1, "colmap_min_points: must be >= 1");
  return problems;
}

std::string detectSequenceLayout(const std::string& dir) {
  if (!fs::is_directory(dir)) throw InputError(dir + ": sequence folder does not exist");
  if (fs::is_directory(dir + "/sparse")) return "colmap";
  if (fs::is_directory(dir + "/cams")) return "mvsnet";
  if (fs::exists(dir + "/rgb.txt") && fs::exists(dir + "/groundtruth.txt")) return "tum";
  if (fs::exists(dir + "/camera-intrinsics.txt") || anyFileEndsWith(dir, ".pose.txt")) return "7scenes";
  throw InputError(dir +
                   ": not a posed sequence: expected an MVSNet dense folder (cams/, images/), a "
                   "COLMAP workspace (sparse/, images/), a 7-Scenes folder "
                   "(frame-NNNNNN.color.jpg + .pose.txt, camera-intrinsics.txt) or a TUM RGB-D "
                   "folder (rgb.txt, groundtruth.txt)");
}

namespace {

// The frames' poses from a tracker's trajectory (PosedSequenceOptions::trajectory_path).
void useTrackerTrajectory(const std::string& path, double max_time_difference_s, PosedSequence* sequence) {
  const std::vector<StampedPose> poses = readTumTrajectory(path);
  if (poses.empty()) throw InputError(path + ": the trajectory has no poses");
  const std::vector<internal::Stamped> stamps = internal::sortedStamps(poses);
  // A tracker run over part of the sequence (amhmvs_odometry --start/--count)
  // maps that part: the frames before its first pose and after its last go.
  const double first = stamps.front().stamp - max_time_difference_s;
  const double last = stamps.back().stamp + max_time_difference_s;
  std::vector<PosedFrame>& frames = sequence->frames;
  frames.erase(std::remove_if(frames.begin(), frames.end(),
                              [&](const PosedFrame& frame) { return frame.stamp < first || frame.stamp > last; }),
               frames.end());
  if (frames.empty()) {
    std::ostringstream why;
    why << path << ": its stamps (" << stamps.front().stamp << " to " << stamps.back().stamp << " s) cover none of "
        << sequence->dir << "'s frames";
    throw InputError(why.str());
  }
  for (PosedFrame& frame : frames) {
    if (frame.true_camera) {
      throw InputError(path + ": " + sequence->dir + " has true poses besides its own (cams_gt/); a trajectory " +
                       "replaces the poses of a sequence that has none");
    }
    const long nearest = internal::nearest(stamps, frame.stamp, max_time_difference_s);
    if (nearest < 0) {
      std::ostringstream why;
      why << path << ": no pose within " << max_time_difference_s << " s of " << frame.name << " (stamp "
          << frame.stamp << ")";
      throw InputError(why.str());
    }
    const Eigen::Isometry3d& tracked = poses[nearest].second;
    frame.true_camera = frame.camera;
    if (frame.ground_truth.present() && !frame.ground_truth.registered) {
      // The tracker's pose is the depth camera's; the colour camera keeps its
      // place on it (the nearest rotation: recorded poses are orthonormal to
      // about 1e-4 only, and their errors would add up here).
      PinholeCamera& depth_camera = frame.ground_truth.depth_camera;
      Eigen::Isometry3d color_on_depth = cameraToWorld(depth_camera).inverse() * cameraToWorld(frame.camera);
      color_on_depth.linear() = Eigen::Quaterniond(color_on_depth.linear()).normalized().toRotationMatrix();
      setCameraToWorld(tracked, &depth_camera);
      setCameraToWorld(tracked * color_on_depth, &frame.camera);
    } else {
      setCameraToWorld(tracked, &frame.camera);
    }
  }
}

}  // namespace

PosedSequence readPosedSequence(const std::string& dir, const PosedSequenceOptions& options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("invalid sequence options:\n" + problems);
  const std::string layout = detectSequenceLayout(dir);
  PosedSequence sequence = layout == "colmap"   ? readColmapSequence(dir, options)
                           : layout == "mvsnet" ? readMvsnetSequence(dir, options)
                           : layout == "tum"    ? readTumSequence(dir, options)
                                                : readSevenScenesSequence(dir, options);
  if (!options.trajectory_path.empty())
    useTrackerTrajectory(options.trajectory_path, options.tum_max_time_difference_s, &sequence);
  return sequence;
}

PosedSequence readMvsnetSequence(const std::string& dir, const PosedSequenceOptions& options) {
  PosedSequence sequence = fromScene(readMvsnetDenseFolder(dir), "mvsnet", dir, options.frame_period_s);
  for (PosedFrame& frame : sequence.frames) {
    char name[32];
    std::snprintf(name, sizeof(name), "%08lld", static_cast<long long>(frame.id));
    const std::string truth = dir + "/depth_gt/" + name + ".pfm";
    if (fs::exists(truth)) frame.ground_truth.path = truth;  // z-depth in metres, registered
    const std::string true_pose = dir + "/cams_gt/" + name + "_cam.txt";
    if (fs::exists(true_pose)) {
      PinholeCamera camera;
      double depth_min, depth_max;
      readMvsnetCam(true_pose, &camera, &depth_min, &depth_max);
      camera.width = frame.camera.width;
      camera.height = frame.camera.height;
      frame.true_camera = camera;
    }
  }
  return sequence;
}

PosedSequence readColmapSequence(const std::string& dir, const PosedSequenceOptions& options) {
  ColmapOptions colmap;
  colmap.min_points = options.colmap_min_points;
  return fromScene(readColmapWorkspace(dir, colmap), "colmap", dir, options.frame_period_s);
}

}  // namespace amhmvs
