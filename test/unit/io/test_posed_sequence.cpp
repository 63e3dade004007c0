// The posed-sequence readers (7-Scenes, TUM RGB-D, MVSNet, COLMAP) on small
// folders written here, their layout detection and their error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

std::string matrixText(const Eigen::Matrix4d& m) {
  std::ostringstream out;
  out.precision(17);
  for (int r = 0; r < 4; ++r) out << m(r, 0) << " " << m(r, 1) << " " << m(r, 2) << " " << m(r, 3) << "\n";
  return out.str();
}

Eigen::Isometry3d testPose(double angle, const Eigen::Vector3d& centre) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  pose.translation() = centre;
  return pose;
}

// A 7-Scenes folder: frames 0, 2 and 10 (numeric, not text, order), 64x48
// PNG colour, 64x48 16-bit depth (a PGM under the .png name: the 16-bit
// reader goes by content), K of a 640x480 Kinect at a tenth.
std::string writeSevenScenes(const test::TempDir& dir) {
  const std::string root = dir.file("7scenes");
  dir.write("7scenes/camera-intrinsics.txt", "58.5 0 32\n0 58.5 24\n0 0 1\n");
  for (int number : {10, 0, 2}) {
    char prefix[64];
    std::snprintf(prefix, sizeof(prefix), "7scenes/frame-%06d", number);
    writePng(dir.file(std::string(prefix) + ".color.png"), ImageU8(64, 48, 3, 90));
    dir.write(std::string(prefix) + ".pose.txt", matrixText(testPose(0.1 * number, {0.01 * number, 0, 1}).matrix()));
    std::string pgm = "P5\n64 48\n65535\n";
    for (int i = 0; i < 64 * 48; ++i) {
      const int value = i == 0 ? 0 : i == 1 ? 65535 : 1500;  // mm; 0 and 65535 invalid
      pgm += static_cast<char>(value >> 8);
      pgm += static_cast<char>(value & 0xFF);
    }
    dir.write(std::string(prefix) + ".depth.png", pgm);
  }
  return root;
}

TEST(PosedSequence, SevenScenesFramesInNumberOrderWithDepthCameraGroundTruth) {
  test::TempDir dir;
  const std::string root = writeSevenScenes(dir);
  EXPECT_EQ(detectSequenceLayout(root), "7scenes");
  const PosedSequence sequence = readPosedSequence(root);
  EXPECT_EQ(sequence.layout, "7scenes");
  ASSERT_EQ(sequence.frames.size(), 3u);
  const int64_t numbers[3] = {0, 2, 10};
  for (size_t i = 0; i < 3; ++i) {
    const PosedFrame& frame = sequence.frames[i];
    EXPECT_EQ(frame.id, numbers[i]);
    EXPECT_DOUBLE_EQ(frame.stamp, numbers[i] / 30.0);
    // Default: the colour camera is the depth camera (registered), K of the file.
    EXPECT_EQ(frame.camera.fx, 58.5);
    EXPECT_EQ(frame.camera.cy, 24);
    EXPECT_EQ(frame.camera.width, 64);
    EXPECT_EQ(frame.camera.height, 48);
    const Eigen::Isometry3d expected = testPose(0.1 * numbers[i], {0.01 * numbers[i], 0, 1});
    EXPECT_TRUE(cameraToWorld(frame.camera).isApprox(expected, 1e-12));
    ASSERT_TRUE(frame.ground_truth.present());
    EXPECT_FALSE(frame.ground_truth.registered);
    EXPECT_EQ(frame.ground_truth.depth_camera.width, 64);
    EXPECT_EQ(frame.ground_truth.metres_per_unit, 0.001);
  }
}

TEST(PosedSequence, SevenScenesConvertedToPnmForBuildsWithoutOpenCv) {
  test::TempDir dir;
  const std::string root = writeSevenScenes(dir);
  for (int number : {0, 2, 10}) {
    char prefix[64];
    std::snprintf(prefix, sizeof(prefix), "%s/frame-%06d", root.c_str(), number);
    fs::remove(std::string(prefix) + ".color.png");
    writePnm(std::string(prefix) + ".color.ppm", ImageU8(64, 48, 3, 90));
    fs::rename(std::string(prefix) + ".depth.png", std::string(prefix) + ".depth.pgm");
  }
  const PosedSequence sequence = readPosedSequence(root);
  ASSERT_EQ(sequence.frames.size(), 3u);
  EXPECT_EQ(sequence.frames[1].name, "frame-000002.color.ppm");
  EXPECT_EQ(sequence.frames[1].camera.width, 64);
  EXPECT_EQ(sequence.frames[1].ground_truth.path, root + "/frame-000002.depth.pgm");
}

TEST(PosedSequence, SevenScenesColourRegistrationOptions) {
  test::TempDir dir;
  const std::string root = writeSevenScenes(dir);
  PosedSequenceOptions options;
  options.color_intrinsics = parseIntrinsics("52.8,52.8,31.6,23.8");
  options.color_offset = Eigen::Vector3d(-0.010, 0, 0);
  options.seven_scenes_frame_rate_hz = 15;
  const PosedSequence sequence = readPosedSequence(root, options);
  const PosedFrame& frame = sequence.frames[2];
  EXPECT_EQ(frame.camera.fx, 52.8);
  EXPECT_EQ(frame.camera.cx, 31.6);
  EXPECT_DOUBLE_EQ(frame.stamp, 10 / 15.0);
  // Same orientation; the centre moved by the offset in the depth camera's frame.
  const PinholeCamera& depth = frame.ground_truth.depth_camera;
  EXPECT_TRUE(frame.camera.R.isApprox(depth.R, 1e-12));
  const Eigen::Vector3d moved = depth.R * (frame.camera.center() - depth.center());  // depth camera frame
  EXPECT_NEAR(moved.x(), -0.010, 1e-12);
  EXPECT_NEAR(moved.norm(), 0.010, 1e-12);
}

// A tracker's trajectory replaces the recorded poses: its poses are the
// depth camera's, the colour camera keeps its offset on it, the recorded
// poses become the truth; a frame without a pose near its stamp is named.
TEST(PosedSequence, TrackerTrajectoryReplacesThePosesAndKeepsThemAsTheTruth) {
  test::TempDir dir;
  const std::string root = writeSevenScenes(dir);
  PosedSequenceOptions options;
  options.color_offset = Eigen::Vector3d(-0.010, 0, 0);
  const PosedSequence recorded = readPosedSequence(root, options);
  std::vector<StampedPose> tracked;
  for (const PosedFrame& frame : recorded.frames) {
    const Eigen::Isometry3d error = testPose(0.01 * frame.id + 0.02, {0.003 * frame.id, -0.01, 0.02});
    tracked.push_back({frame.stamp + 0.001, cameraToWorld(frame.ground_truth.depth_camera) * error});
  }
  writeTumTrajectory(dir.file("tracked.txt"), {tracked.rbegin(), tracked.rend()}, "");  // any order
  options.trajectory_path = dir.file("tracked.txt");
  const PosedSequence sequence = readPosedSequence(root, options);
  ASSERT_EQ(sequence.frames.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const PosedFrame& frame = sequence.frames[i];
    const PosedFrame& truth = recorded.frames[i];
    EXPECT_TRUE(cameraToWorld(frame.ground_truth.depth_camera).isApprox(tracked[i].second, 1e-12)) << i;
    const Eigen::Isometry3d offset = cameraToWorld(frame.ground_truth.depth_camera).inverse() * cameraToWorld(frame.camera);
    const Eigen::Isometry3d true_offset =
        cameraToWorld(truth.ground_truth.depth_camera).inverse() * cameraToWorld(truth.camera);
    EXPECT_TRUE(offset.isApprox(true_offset, 1e-12)) << i;
    ASSERT_TRUE(frame.true_camera.has_value()) << i;
    EXPECT_TRUE(cameraToWorld(*frame.true_camera).isApprox(cameraToWorld(truth.camera), 1e-12)) << i;
  }
  // The truth's depth camera, back where it was recorded.
  const DepthMapView placed = trueSurfaceView({sequence.frames[2].ground_truth.depth_camera, ImageF()}, sequence.frames[2]);
  EXPECT_TRUE(cameraToWorld(placed.camera).isApprox(cameraToWorld(recorded.frames[2].ground_truth.depth_camera), 1e-12));

  // A tracker run over the first two frames maps those two; one with a gap
  // between its poses is refused at the frame it has no pose for.
  writeTumTrajectory(dir.file("short.txt"), {tracked[0], tracked[1]}, "");
  options.trajectory_path = dir.file("short.txt");
  const PosedSequence part = readPosedSequence(root, options);
  ASSERT_EQ(part.frames.size(), 2u);
  EXPECT_EQ(part.frames[1].name, recorded.frames[1].name);
  EXPECT_TRUE(cameraToWorld(part.frames[1].ground_truth.depth_camera).isApprox(tracked[1].second, 1e-12));
  writeTumTrajectory(dir.file("gap.txt"), {tracked[0], tracked[2]}, "");
  options.trajectory_path = dir.file("gap.txt");
  EXPECT_INPUT_ERROR(readPosedSequence(root, options),
                     "gap.txt: no pose within 0.02 s of " + recorded.frames[1].name, "stamp");
  writeTumTrajectory(dir.file("later.txt"), {{100.0, tracked[0].second}}, "");
  options.trajectory_path = dir.file("later.txt");
  EXPECT_INPUT_ERROR(readPosedSequence(root, options), "later.txt: its stamps (100 to 100 s) cover none of",
                     "frames");
  writeTumTrajectory(dir.file("empty.txt"), {}, "nothing");
  options.trajectory_path = dir.file("empty.txt");
  EXPECT_INPUT_ERROR(readPosedSequence(root, options), "empty.txt", "has no poses");
}

TEST(PosedSequence, SevenScenesErrorsNameFileAndLine) {
  test::TempDir dir;
  const std::string root = writeSevenScenes(dir);
  dir.write("7scenes/frame-000002.pose.txt", "1 0 0 0\n0 1 0 x\n0 0 1 0\n0 0 0 1\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "frame-000002.pose.txt: line 2", "'x'");
  dir.write("7scenes/frame-000002.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "frame-000002.pose.txt", "bottom row");
  dir.write("7scenes/frame-000002.pose.txt", "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "frame-000002.pose.txt", "rotation");
  fs::remove(dir.file("7scenes/frame-000002.pose.txt"));
  EXPECT_INPUT_ERROR(readPosedSequence(root), "frame-000002.pose.txt", "missing pose");
  dir.write("7scenes/camera-intrinsics.txt", "58.5 0 32\n0 58.5 24\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "camera-intrinsics.txt", "3x3");
}

// A TUM RGB-D folder named like the freiburg2 recordings.
std::string writeTum(const test::TempDir& dir) {
  const std::string root = dir.file("rgbd_dataset_freiburg2_xyz");
  fs::create_directories(root + "/rgb");
  writePng(root + "/rgb/1.000000.png", ImageU8(640, 480, 1, 90));  // the K needs the size
  dir.write("rgbd_dataset_freiburg2_xyz/rgb.txt",
            "# color images\n# file: 'x.bag'\n# timestamp filename\n"
            "1.000000 rgb/1.000000.png\n1.100000 rgb/1.000000.png\n1.500000 rgb/1.000000.png\n"
            "1.600000 rgb/1.000000.png\n");
  dir.write("rgbd_dataset_freiburg2_xyz/depth.txt", "# depth\n1.005 depth/1.png\n1.590 depth/2.png\n");
  // Poses near 1.0 and 1.1 and 1.6, none near 1.5 (that frame is left out).
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  std::ostringstream poses;
  poses.precision(17);
  poses << "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
  for (double stamp : {0.99, 1.11, 1.61}) {
    poses << stamp << " " << stamp << " 0.5 -1 " << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
  }
  dir.write("rgbd_dataset_freiburg2_xyz/groundtruth.txt", poses.str());
  return root;
}

TEST(PosedSequence, TumAssociatesByNearestStampWithinTolerance) {
  test::TempDir dir;
  const std::string root = writeTum(dir);
  EXPECT_EQ(detectSequenceLayout(root), "tum");
  const PosedSequence sequence = readPosedSequence(root);
  ASSERT_EQ(sequence.frames.size(), 3u);  // 1.5 has no pose within 0.02 s
  EXPECT_EQ(sequence.frames[0].id, 0);
  EXPECT_EQ(sequence.frames[1].id, 1);
  EXPECT_EQ(sequence.frames[2].id, 3);
  EXPECT_DOUBLE_EQ(sequence.frames[2].stamp, 1.6);
  // freiburg2 intrinsics from the folder name; the pose of the nearest stamp.
  const PinholeCamera& camera = sequence.frames[1].camera;
  EXPECT_EQ(camera.fx, 520.9);
  EXPECT_EQ(camera.cy, 249.7);
  EXPECT_EQ(camera.width, 640);
  EXPECT_TRUE(camera.center().isApprox(Eigen::Vector3d(1.11, 0.5, -1), 1e-12));
  EXPECT_TRUE(camera.R.transpose().isApprox(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix(), 1e-12));
  // Depth: registered, 5000 units per metre, only where a depth stamp is near.
  EXPECT_EQ(sequence.frames[0].ground_truth.path, root + "/depth/1.png");
  EXPECT_TRUE(sequence.frames[0].ground_truth.registered);
  EXPECT_DOUBLE_EQ(sequence.frames[0].ground_truth.metres_per_unit, 1 / 5000.0);
  EXPECT_FALSE(sequence.frames[1].ground_truth.present());
  EXPECT_EQ(sequence.frames[2].ground_truth.path, root + "/depth/2.png");

  PosedSequenceOptions options;
  options.color_intrinsics = parseIntrinsics("ros");
  options.tum_max_time_difference_s = 0.2;
  const PosedSequence wide = readPosedSequence(root, options);
  EXPECT_EQ(wide.frames.size(), 4u);
  EXPECT_EQ(wide.frames[0].camera.cx, 319.5);
}

TEST(PosedSequence, TumErrorsNameFileAndLine) {
  test::TempDir dir;
  const std::string root = writeTum(dir);
  dir.write("rgbd_dataset_freiburg2_xyz/groundtruth.txt", "# x\n1.0 0 0 0 0 0 0\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "groundtruth.txt: line 2", "8 fields");
  dir.write("rgbd_dataset_freiburg2_xyz/groundtruth.txt", "1.0 0 0 0 0 0 0 2\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "groundtruth.txt: line 1", "unit length");
  dir.write("rgbd_dataset_freiburg2_xyz/groundtruth.txt", "5.0 0 0 0 0 0 0 1\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "no colour frame", "groundtruth.txt");
  dir.write("rgbd_dataset_freiburg2_xyz/rgb.txt", "1.0 rgb/1.png\nabc rgb/2.png\n");
  EXPECT_INPUT_ERROR(readPosedSequence(root), "rgb.txt: line 2", "'abc'");
}

// An MVSNet folder of views 1 and 3 (40x30), view 3 with true depth.
std::string writeMvsnet(const test::TempDir& dir) {
  const std::string root = dir.file("mvsnet");
  for (const char* sub : {"/depth_gt", "/images", "/cams"}) fs::create_directories(root + sub);
  for (int id : {3, 1}) {
    char name[16];
    std::snprintf(name, sizeof(name), "%08d", id);
    PinholeCamera camera = test::centredCamera(40, 30, 50);
    camera.t = Eigen::Vector3d(-0.1 * id, 0, 0);
    writePng(root + "/images/" + name + ".png", ImageU8(40, 30, 1, 7));
    writeMvsnetCam(root + "/cams/" + name + "_cam.txt", camera, 1.0, 4.0);
    if (id == 3) writePfm(root + "/depth_gt/" + name + ".pfm", ImageF(40, 30, 1, 2.0f));
  }
  return root;
}

TEST(PosedSequence, MvsnetFolderWithGroundTruthDepth) {
  test::TempDir dir;
  const std::string root = writeMvsnet(dir);
  EXPECT_EQ(detectSequenceLayout(root), "mvsnet");
  PosedSequenceOptions options;
  options.frame_period_s = 0.5;
  const PosedSequence sequence = readPosedSequence(root, options);
  ASSERT_EQ(sequence.frames.size(), 2u);
  EXPECT_EQ(sequence.frames[0].id, 1);
  EXPECT_EQ(sequence.frames[1].id, 3);
  EXPECT_DOUBLE_EQ(sequence.frames[1].stamp, 0.5);
  EXPECT_NEAR(sequence.frames[1].depth_min, 1.0, 1e-6);
  EXPECT_NEAR(sequence.frames[1].depth_max, 4.0, 1e-6);
  EXPECT_NEAR(sequence.frames[1].camera.center().x(), 0.3, 1e-6);
  EXPECT_FALSE(sequence.frames[0].ground_truth.present());
  EXPECT_EQ(sequence.frames[1].ground_truth.path, root + "/depth_gt/00000003.pfm");
  EXPECT_TRUE(sequence.frames[1].ground_truth.registered);
}

TEST(PosedSequence, ColmapWorkspaceInImageIdOrder) {
  test::TempDir dir;
  const std::string root = dir.file("colmap");
  dir.write("colmap/sparse/cameras.txt", "1 PINHOLE 40 30 50 50 19.5 14.5\n");
  // Two images 0.5 apart along x, looking along +z; 12 points both observe.
  std::ostringstream observations, points;
  for (int k = 0; k < 12; ++k) {
    observations << "1.5 2.5 " << k << " ";
    points << k << " " << 0.1 * k << " 0 " << 5 + k << " 1 2 3 0.5 2 " << k << " 4 " << k << "\n";
  }
  dir.write("colmap/sparse/images.txt", "4 1 0 0 0 -0.5 0 0 1 b.pgm\n" + observations.str() +
                                            "\n2 1 0 0 0 0 0 0 1 a.pgm\n" + observations.str() + "\n");
  dir.write("colmap/sparse/points3D.txt", points.str());
  fs::create_directories(root + "/images");
  writePnm(root + "/images/a.pgm", ImageU8(40, 30, 1, 7));
  writePnm(root + "/images/b.pgm", ImageU8(40, 30, 1, 7));
  EXPECT_EQ(detectSequenceLayout(root), "colmap");
  const PosedSequence sequence = readPosedSequence(root);
  ASSERT_EQ(sequence.frames.size(), 2u);
  EXPECT_EQ(sequence.frames[0].id, 2);
  EXPECT_EQ(sequence.frames[0].name, "a.pgm");
  EXPECT_EQ(sequence.frames[1].id, 4);
  EXPECT_NEAR(sequence.frames[1].camera.center().x(), 0.5, 1e-12);
  EXPECT_GT(sequence.frames[1].depth_min, 0);  // from the points
  EXPECT_FALSE(sequence.frames[0].ground_truth.present());
}

TEST(PosedSequence, LayoutDetectionAndIntrinsicsNames) {
  test::TempDir dir;
  EXPECT_INPUT_ERROR(detectSequenceLayout(dir.file("none")), "none", "does not exist");
  dir.write("other/readme.txt", "x");
  EXPECT_INPUT_ERROR(detectSequenceLayout(dir.file("other")), "other", "TUM RGB-D");
  EXPECT_EQ(parseIntrinsics("freiburg1").fx, 517.3);
  EXPECT_EQ(parseIntrinsics("freiburg3").cy, 247.6);
  EXPECT_EQ(parseIntrinsics("ros").cx, 319.5);
  const Intrinsics k = parseIntrinsics("500,501,300.5,200");
  EXPECT_EQ(k.fy, 501);
  EXPECT_EQ(k.cx, 300.5);
  EXPECT_INPUT_ERROR(parseIntrinsics("500,501,300"), "500,501,300", "fx,fy,cx,cy");
  EXPECT_INPUT_ERROR(parseIntrinsics("500,-1,3,4"), "intrinsics", "fx, fy > 0");
  EXPECT_INPUT_ERROR(parseIntrinsics("kinect"), "kinect", "freiburg1");
  PosedSequenceOptions bad;
  bad.tum_depth_units_per_metre = 0;
  EXPECT_INPUT_ERROR(readPosedSequence(dir.file("other"), bad), "tum_depth_units_per_metre", "> 0");
}

}  // namespace
}  // namespace amhmvs
