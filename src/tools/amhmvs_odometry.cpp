// amhmvs_odometry: a real RGB-D tracker's trajectory over a recorded
// sequence, and its error against the sequence's own poses. The tracker is
// OpenCV contrib's frame-to-keyframe RGB-D odometry (no loop closure, no
// map), as a SLAM front end without its back end would give: the poses a
// mapper behind a real tracker has to live with.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/rgbd.hpp>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/eval/trajectory_error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "tool_main.h"
#include "tool_options.h"

namespace amhmvs {
namespace {

const char* const kUsage =
    "usage: amhmvs_odometry SEQUENCE_DIR TRAJECTORY.txt [options]\n"
    "\n"
    "Tracks a recorded RGB-D sequence (7-Scenes / tsdf-fusion or TUM RGB-D folder) with\n"
    "OpenCV's RGB-D odometry, each frame against the tracker's last keyframe (no loop\n"
    "closure), and writes the trajectory in the TUM format (stamp tx ty tz qx qy qz qw,\n"
    "camera-to-world of the depth camera, the frame the sequence's own poses are in). It\n"
    "starts at the sequence's first pose. The error against the sequence's poses is\n"
    "printed and, with --report, written as JSON: ATE (rigid alignment), RPE and the pixel\n"
    "misalignment over the keyframe pairs the mapper picks on the reference (5 cm / 5 deg).\n"
    "\n"
    "  --method NAME              rgbd_icp (default: photometric + geometric), rgbd, icp\n"
    "  --report FILE.json         the error report\n"
    "  --start N, --count N       frames of the sequence (default: from 0, all)\n"
    "  --stride N                 every Nth frame (default 1)\n"
    "  --keyframe_translation M   the tracker takes a new keyframe after this much motion\n"
    "                             (default 0.1 m) ...\n"
    "  --keyframe_rotation_deg D  ... or this much rotation (default 10), or when a frame\n"
    "                             fails to align\n"
    "  --max_depth M              depths beyond are not used (default 4 m)\n"
    "  --intrinsics SPEC          colour intrinsics (amhmvs_map's: fitted7scenes, ros,\n"
    "                             freiburgN or fx,fy,cx,cy); 7-Scenes default: the depth\n"
    "                             camera's\n"
    "  --color_offset X,Y,Z       7-Scenes: the colour camera's centre in the depth camera\n"
    "                             (metres; default 0,0,0)\n";

struct OdometryOptions {
  std::string method = "rgbd_icp";
  std::string report_path;
  size_t start = 0, count = 0, stride = 1;
  double keyframe_translation_m = 0.1, keyframe_rotation_deg = 10;
  double max_depth_m = 4;
  PosedSequenceOptions sequence;
};

OdometryOptions parseArguments(const std::vector<std::string>& arguments) {
  OdometryOptions options;
  for (size_t i = 0; i < arguments.size(); ++i) {
    std::string name, value;
    nextOption(arguments, &i, {}, &name, &value);
    if (name == "method") {
      if (value != "rgbd_icp" && value != "rgbd" && value != "icp") {
        throw InputError("option --method: '" + value + "' is none of rgbd_icp, rgbd, icp");
      }
      options.method = value;
    } else if (name == "report") {
      options.report_path = value;
    } else if (name == "start" || name == "count" || name == "stride") {
      const long long n = parseValue<long long>(name, value);
      if (n < 0 || (name == "stride" && n < 1)) throw InputError("option --" + name + ": '" + value + "' is out of range");
      (name == "start" ? options.start : name == "count" ? options.count : options.stride) = static_cast<size_t>(n);
    } else if (name == "keyframe_translation" || name == "keyframe_rotation_deg" || name == "max_depth") {
      const double v = parseValue<double>(name, value);
      if (!(v > 0) || !std::isfinite(v)) throw InputError("option --" + name + ": must be positive (got " + value + ")");
      (name == "keyframe_translation" ? options.keyframe_translation_m
       : name == "max_depth"          ? options.max_depth_m
                                      : options.keyframe_rotation_deg) = v;
    } else if (name == "intrinsics") {
      options.sequence.color_intrinsics = parseIntrinsics(value);
    } else if (name == "color_offset") {
      options.sequence.color_offset = parseVector3(name, value);
    } else {
      throw InputError("unknown option --" + name + " (amhmvs_odometry --help lists them)");
    }
  }
  return options;
}

// One frame as the odometry sees it, in the depth camera: grey (the colour
// image resampled into the depth camera where they are not registered),
// depth in metres (NaN: none) and the mask of pixels with both.
struct OdometryFrame {
  cv::Mat grey, depth, mask;
};

float bilinear(const ImageU8& grey, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= grey.width || y0 + 1 >= grey.height) return -1;
  const double fx = x - x0, fy = y - y0;
  const auto at = [&](int u, int v) { return static_cast<double>(grey.at(u, v)); };
  return static_cast<float>((1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                            fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1)));
}

OdometryFrame odometryFrame(const PosedFrame& frame, const DepthMapView& depth, double max_depth_m) {
  const ImageU8 grey = toGray(readImage(frame.image_path));
  if (grey.width != frame.camera.width || grey.height != frame.camera.height) {
    throw InputError(frame.image_path + ": " + std::to_string(grey.width) + "x" + std::to_string(grey.height) +
                     " but its camera is " + std::to_string(frame.camera.width) + "x" +
                     std::to_string(frame.camera.height));
  }
  const PinholeCamera& d = depth.camera;
  OdometryFrame out;
  out.grey = cv::Mat(d.height, d.width, CV_8UC1, cv::Scalar(0));
  out.depth = cv::Mat(d.height, d.width, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  out.mask = cv::Mat(d.height, d.width, CV_8UC1, cv::Scalar(0));
  // Depth camera -> colour camera (world poses of the same instant).
  const Eigen::Isometry3d depth_to_color = cameraToWorld(frame.camera).inverse() * cameraToWorld(d);
  for (int y = 0; y < d.height; ++y) {
    for (int x = 0; x < d.width; ++x) {
      const float z = depth.depth.at(x, y);
      if (!(z > 0) || !std::isfinite(z) || z > max_depth_m) continue;
      const Eigen::Vector3d in_color = depth_to_color * d.backproject(x, y, z);
      if (in_color.z() <= 0) continue;
      const Eigen::Vector2d pixel = frame.camera.project(in_color);
      const float value = bilinear(grey, pixel.x(), pixel.y());
      if (value < 0) continue;
      out.grey.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(value));
      out.depth.at<float>(y, x) = z;
      out.mask.at<uint8_t>(y, x) = 255;
    }
  }
  return out;
}

cv::Ptr<cv::rgbd::Odometry> makeOdometry(const std::string& method, const PinholeCamera& camera, double max_depth_m) {
  cv::Mat k = (cv::Mat_<float>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const float max_depth = static_cast<float>(max_depth_m);
  if (method == "rgbd") return cv::rgbd::RgbdOdometry::create(k, 0, max_depth);
  if (method == "icp") return cv::rgbd::ICPOdometry::create(k, 0, max_depth);
  return cv::rgbd::RgbdICPOdometry::create(k, 0, max_depth);
}

// OpenCV's odometry takes and gives 4x4 CV_64F rigid motions. Its rotation
// comes from a first-order update and is off orthonormal by ~1e-4 per frame
// (measured on redkitchen): the nearest rotation is taken, or the error
// would compound along the chain of poses.
Eigen::Isometry3d toIsometry(const cv::Mat& rt) {
  Eigen::Matrix3d rotation;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rotation(r, c) = rt.at<double>(r, c);
    pose.translation()(r) = rt.at<double>(r, 3);
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  pose.linear() = svd.matrixU() * svd.matrixV().transpose();
  return pose;
}

cv::Mat toMat(const Eigen::Isometry3d& pose) {
  cv::Mat m(4, 4, CV_64FC1);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m.at<double>(r, c) = pose.matrix()(r, c);
  }
  return m;
}

int run(const std::vector<std::string>& args) {
  const std::string sequence_dir = args[0], trajectory_path = args[1];
  const OdometryOptions options = parseArguments({args.begin() + 2, args.end()});
  const PosedSequence sequence = readPosedSequence(sequence_dir, options.sequence);
  std::vector<const PosedFrame*> frames;
  for (size_t i = options.start; i < sequence.frames.size(); i += options.stride) {
    if (options.count > 0 && frames.size() == options.count) break;
    frames.push_back(&sequence.frames[i]);
  }
  if (frames.size() < 2) {
    throw InputError(sequence_dir + ": " + std::to_string(frames.size()) + " frames from --start " +
                     std::to_string(options.start) + " (of " + std::to_string(sequence.frames.size()) +
                     "): the odometry needs at least 2");
  }
  for (const PosedFrame* frame : frames) {
    if (!frame->ground_truth.present()) throw InputError(frame->image_path + ": no depth image beside it");
  }
  const auto depthOf = [&](size_t i) { return readGroundTruthDepth(frames[i]->ground_truth, frames[i]->camera); };

  // The tracker: each frame against its last keyframe, started from the
  // motion of the frame before (constant velocity), as a real front end.
  DepthMapView first = depthOf(0);
  const PinholeCamera depth_camera = first.camera;
  const cv::Ptr<cv::rgbd::Odometry> odometry = makeOdometry(options.method, depth_camera, options.max_depth_m);
  OdometryFrame keyframe = odometryFrame(*frames[0], first, options.max_depth_m);
  std::vector<Eigen::Isometry3d> estimated{cameraToWorld(depth_camera)}, reference{cameraToWorld(depth_camera)};
  Eigen::Isometry3d keyframe_pose = estimated[0], step = Eigen::Isometry3d::Identity();
  size_t keyframes = 1, failures = 0;
  for (size_t i = 1; i < frames.size(); ++i) {
    const DepthMapView depth = depthOf(i);
    reference.push_back(cameraToWorld(depth.camera));
    OdometryFrame current = odometryFrame(*frames[i], depth, options.max_depth_m);
    const Eigen::Isometry3d predicted = estimated.back() * step;
    // Rt carries points of the keyframe into the current frame: current-from-keyframe.
    cv::Mat rt;
    const bool aligned = odometry->compute(keyframe.grey, keyframe.depth, keyframe.mask, current.grey, current.depth,
                                           current.mask, rt, toMat(predicted.inverse() * keyframe_pose));
    const Eigen::Isometry3d pose = aligned ? keyframe_pose * toIsometry(rt).inverse() : predicted;
    if (!aligned) ++failures;
    step = estimated.back().inverse() * pose;
    estimated.push_back(pose);
    const Eigen::Isometry3d since_keyframe = keyframe_pose.inverse() * pose;
    if (!aligned || since_keyframe.translation().norm() >= options.keyframe_translation_m ||
        rotationAngleDeg(since_keyframe.rotation()) >= options.keyframe_rotation_deg) {
      keyframe = std::move(current);
      keyframe_pose = pose;
      ++keyframes;
    }
  }

  std::vector<StampedPose> trajectory;
  for (size_t i = 0; i < frames.size(); ++i) trajectory.push_back({frames[i]->stamp, estimated[i]});
  writeTumTrajectory(trajectory_path, trajectory,
                     "amhmvs_odometry " + options.method + " over " + sequence_dir + "\n" +
                         "camera-to-world of the depth camera; stamp tx ty tz qx qy qz qw");
  // The report is of the poses as written (the file's unit quaternions).
  std::vector<Eigen::Isometry3d> written;
  for (const StampedPose& pose : readTumTrajectory(trajectory_path)) written.push_back(pose.second);
  const TrajectoryError error =
      trajectoryError(written, reference, depth_camera, [&](size_t i) { return depthOf(i).depth; });
  std::printf("amhmvs_odometry: %zu frames, %zu tracker keyframes, %zu failed to align (%s)\n", frames.size(),
              keyframes, failures, options.method.c_str());
  std::printf("  ATE %.1f mm RMSE (median %.1f, max %.1f)", error.ate_rmse_m * 1e3, error.ate_median_m * 1e3,
              error.ate_max_m * 1e3);
  if (error.keyframe_pairs == 0) {
    std::printf("; no keyframe pairs (the reference moves less than a keyframe's motion)\n");
  } else {
    std::printf("; over %zu keyframe pairs: RPE %.1f mm / %.2f deg RMSE,\n", error.keyframe_pairs,
                error.rpe_translation_rmse_m * 1e3, error.rpe_rotation_rmse_deg);
    std::printf("  misalignment %.2f px median, %.2f px 90th percentile, %.2f px max\n", error.misalignment_median_px,
                error.misalignment_p90_px, error.misalignment_max_px);
  }
  if (!options.report_path.empty()) {
    std::string json = trajectoryErrorJson(error);
    json.erase(json.rfind("\n}"));  // the tracker's own counts join the object
    json += ",\n  \"method\": \"" + options.method + "\",\n  \"tracker_keyframes\": " + std::to_string(keyframes) +
            ",\n  \"failed_to_align\": " + std::to_string(failures) + "\n}\n";
    writeFileAtomically(options.report_path, json, "report");
  }
  return 0;
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  return amhmvs::runToolMain("amhmvs_odometry", amhmvs::kUsage, argc, argv, 2, true, amhmvs::run);
}
