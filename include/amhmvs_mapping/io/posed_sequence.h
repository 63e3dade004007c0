// Recorded posed image sequences as people keep them on disk, read into one
// ordered list of frames (image, pinhole camera with its world-to-camera
// pose, stamp, optional ground-truth depth). The layout is detected from the
// folder:
//   - MVSNet dense folder (cams/, images/, pair.txt; depth_gt/NNNNNNNN.pfm and
//     cams_gt/NNNNNNNN_cam.txt as written by amhmvs_synthetic are its ground
//     truth);
//   - COLMAP workspace (sparse/[0/] text or .bin, images/);
//   - 7-Scenes / tsdf-fusion: frame-NNNNNN.color.(jpg|png|ppm|pgm), .pose.txt
//     (camera-to-world of the DEPTH camera, metres), .depth.png|pgm (uint16 mm,
//     0 and 65535 invalid) and camera-intrinsics.txt (the depth camera's K);
//   - TUM RGB-D: rgb.txt, depth.txt, groundtruth.txt (stamp tx ty tz qx qy qz
//     qw, camera-to-world), associated by nearest stamp; depth registered to
//     the colour camera, 5000 units per metre.
// Frames without a stamp of their own (MVSNet, COLMAP) get
// index * frame_period_s.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs {

// Ground-truth z-depth of a frame, only for reports.
struct GroundTruthDepthSource {
  std::string path;        // empty: none. PFM (metres) or 16-bit PNG/PGM
  double metres_per_unit = 1;  // PFM 1, 7-Scenes 0.001, TUM 1/5000
  // True: registered to the colour image (any resolution, resampled to the
  // nearest sample). False: a depth camera of its own (depth_camera: K at the
  // file's resolution and pose), reprojected into the colour camera.
  bool registered = true;
  PinholeCamera depth_camera;
  // Stored values that mean "no depth" besides 0 (7-Scenes: 65535).
  double invalid_value = -1;

  bool present() const { return !path.empty(); }
};

struct PosedFrame {
  int64_t id = 0;          // file number (7-Scenes, MVSNet), image id (COLMAP), index (TUM)
  std::string name;        // file name of the colour image
  double stamp = 0;        // seconds, non-decreasing over the sequence
  std::string image_path;
  PinholeCamera camera;    // colour camera at the image file's resolution
  double depth_min = 0, depth_max = 0;  // given depth range (MVSNet, COLMAP), else 0
  GroundTruthDepthSource ground_truth;
  // The true pose where `camera` is a tracker's (MVSNet cams_gt/NNNNNNNN_cam.txt,
  // as amhmvs_synthetic --realism writes it): for reports only.
  std::optional<PinholeCamera> true_camera;
};

struct PosedSequence {
  std::string layout;  // "mvsnet", "colmap", "7scenes", "tum"
  std::string dir;
  std::vector<PosedFrame> frames;  // in recording order
};

// Pinhole intrinsics at the colour image's resolution.
struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  bool set() const { return fx > 0; }
};

// The camera of an image file: intrinsics, the file's size (from its header,
// else decoded) and a camera-to-world pose. Throws InputError naming
// `pose_origin` for a pose that is not rigid.
PinholeCamera cameraOfImage(const Intrinsics& intrinsics, const std::string& image_path,
                            const Eigen::Isometry3d& camera_to_world, const std::string& pose_origin);

// Named colour intrinsics: "freiburg1", "freiburg2", "freiburg3" (TUM RGB-D's
// calibrated colour cameras, distortion ignored), "ros" (525, 525, 319.5,
// 239.5, the ROS default for 640x480 Kinect-type sensors), "fitted7scenes"
// (528, 528, 316, 238: the colour camera of ../shared/data/redkitchen_7scenes
// fitted to its depth) or "fx,fy,cx,cy". Throws InputError otherwise.
Intrinsics parseIntrinsics(const std::string& text);

struct PosedSequenceOptions {
  // Colour intrinsics (7-Scenes, TUM). Unset: 7-Scenes takes
  // camera-intrinsics.txt (colour treated as registered to depth, as the
  // tsdf-fusion code does); TUM takes freiburgN when the folder name says
  // rgbd_dataset_freiburgN_..., else "ros".
  Intrinsics color_intrinsics;
  // 7-Scenes: colour camera centre in the depth camera frame (metres), same
  // orientation. Default 0 (registered).
  Eigen::Vector3d color_offset = Eigen::Vector3d::Zero();
  double seven_scenes_frame_rate_hz = 30;  // stamp = file number / rate
  double tum_max_time_difference_s = 0.02;  // association of rgb, depth and pose
  double tum_depth_units_per_metre = 5000;
  double frame_period_s = 1;  // stamps of layouts without any
  int colmap_min_points = 10;
  // A tracker's trajectory (TUM format, e.g. amhmvs_odometry's) used instead
  // of the sequence's own poses. Its poses are of the camera the sequence's
  // poses are of (7-Scenes: the depth camera; the others: the colour
  // camera), matched to the frames by stamp (the nearest, within
  // tum_max_time_difference_s; a frame between the trajectory's first and
  // last pose without one is an error, the frames before and after it are
  // left out: a tracker run over part of the sequence maps that part); the
  // colour camera keeps its place on the depth camera. The sequence's own
  // poses become the frames' true_camera, for reports. Empty: the sequence's poses.
  std::string trajectory_path;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// "mvsnet", "colmap", "7scenes" or "tum"; throws InputError naming the folder
// and the layouts when it is none of them.
std::string detectSequenceLayout(const std::string& dir);

// Reads the sequence in `dir` (layout detected). Throws InputError naming the
// file (and line) for malformed input, a missing folder or file, and an empty
// sequence.
PosedSequence readPosedSequence(const std::string& dir, const PosedSequenceOptions& options = {});

// The layouts one by one (readPosedSequence dispatches to these).
PosedSequence readMvsnetSequence(const std::string& dir, const PosedSequenceOptions& options);
PosedSequence readColmapSequence(const std::string& dir, const PosedSequenceOptions& options);
PosedSequence readSevenScenesSequence(const std::string& dir, const PosedSequenceOptions& options);
PosedSequence readTumSequence(const std::string& dir, const PosedSequenceOptions& options);

}  // namespace amhmvs
