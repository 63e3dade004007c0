// Rolling-shutter rectification (rolling_shutter.h): the angular velocity of
// two poses, the rectified image against a global-shutter render of the same
// turning camera, and the online mapper's use of it (which keyframes are
// rectified with which motion, and which are counted as used as they came).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

#include "amhmvs_mapping/simulation/realistic_capture.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

// Camera-to-world rotation `turn` (camera frame) after `camera`'s.
PinholeCamera turned(const PinholeCamera& camera, const Eigen::Vector3d& turn) {
  PinholeCamera out = camera;
  Eigen::Isometry3d pose = cameraToWorld(camera);
  pose.linear() = pose.linear() * Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
  setCameraToWorld(pose, &out);
  return out;
}

TEST(RollingShutter, AngularVelocityIsTheTurnInTheCameraFramePerSecond) {
  PinholeCamera earlier = test::centredCamera(64, 48, 50);
  setCameraToWorld(test::poseAt({1, 2, 3}, 30), &earlier);
  const Eigen::Vector3d turn(0.02, -0.05, 0.01);
  const Eigen::Vector3d velocity = cameraAngularVelocity(earlier, turned(earlier, turn), 0.5);
  EXPECT_LT((velocity - turn / 0.5).norm(), 1e-12);
}

// A camera turning at a constant rate about its own centre (pure rotation:
// what the rectification models exactly) in the synthetic room.
TEST(RollingShutter, RectifiedImageIsTheGlobalShutterImageOfATurningCamera) {
  constexpr int kWidth = 128, kHeight = 96;
  const SyntheticWorld world = makeIndoorRoomWorld(2);
  const PinholeCamera start = smoothRoomTrajectory(2, kWidth, kHeight, 2, 0.5)(0, 0.0);
  const Eigen::Vector3d angular_velocity(0.25, 0.6, 0.1);  // rad/s, camera frame
  const CameraTrajectory turning = [&](int, double seconds) { return turned(start, angular_velocity * seconds); };
  RealismOptions rolling;
  rolling.rolling_shutter_s = 0.05;  // the image moves by ~3 px from the first to the last row
  const ImageU8 global = renderRealisticView(world, turning, 0, RealismOptions(), {}).image;
  const ImageU8 raw = renderRealisticView(world, turning, 0, rolling, {}).image;
  const ImageU8 rectified = rectifyRollingShutter(raw, start, angular_velocity, rolling.rolling_shutter_s);

  // Bilinear resampling smooths the room's fine texture: the floor of the
  // comparison is the global image resampled by the same motion there and back.
  const ImageU8 there_and_back =
      rectifyRollingShutter(rectifyRollingShutter(global, start, angular_velocity, rolling.rolling_shutter_s), start,
                            -angular_velocity, rolling.rolling_shutter_s);
  const double before = test::meanDifference(raw, global, 6), after = test::meanDifference(rectified, global, 6);
  const double floor = test::meanDifference(there_and_back, global, 6);
  const double wrong_way = test::meanDifference(rectifyRollingShutter(raw, start, -angular_velocity, rolling.rolling_shutter_s), global, 6);
  std::printf("grey levels from the global-shutter image: as it came %.2f, rectified %.2f, the other way %.2f, "
              "resampling there and back %.2f\n", before, after, wrong_way, floor);
  // Measured: 14.76, 5.00, 21.58, 7.24 (one resampling is what is left).
  EXPECT_GT(before, 10.0);
  EXPECT_LT(after, 0.4 * before);
  EXPECT_LT(after, floor);
  EXPECT_GT(wrong_way, before);
  // A global shutter, or no motion: the image as it came, bit for bit.
  EXPECT_EQ(rectifyRollingShutter(raw, start, angular_velocity, 0).data, raw.data);
  EXPECT_EQ(rectifyRollingShutter(raw, start, Eigen::Vector3d::Zero(), 0.05).data, raw.data);
}

// A keyframe image with texture (the tests' keyframes are uniform).
Keyframe texturedKeyframe(int64_t id, double stamp, double x, double yaw_deg) {
  Keyframe keyframe = test::smallKeyframe(id, stamp, test::poseAt({x, 0, 0}, yaw_deg), 3, 0);
  for (int y = 0; y < keyframe.image.height; ++y)
    for (int u = 0; u < keyframe.image.width; ++u)
      for (int c = 0; c < 3; ++c) keyframe.image.at(u, y, c) = static_cast<uint8_t>((u * 37 + y * 91 + c * 50) % 256);
  return keyframe;
}

TEST(RollingShutter, OnlineMapperRectifiesWithTheMotionFromTheKeyframeBefore) {
  OnlineMapperOptions options = test::wallOptions();
  options.rolling_shutter.readout_s = 0.05;
  options.rolling_shutter.max_interval_s = 1.0;
  OnlineMapper mapper(options, test::wallDepth);
  const double readout = options.rolling_shutter.readout_s;
  const auto expected = [&](const Keyframe& keyframe, const Keyframe& before) {
    const double seconds = keyframe.stamp - before.stamp;
    return rectifyRollingShutter(keyframe.image, keyframe.camera,
                                 cameraAngularVelocity(before.camera, keyframe.camera, seconds), readout);
  };
  const Keyframe k0 = texturedKeyframe(0, 0.0, 0.0, 0), k1 = texturedKeyframe(1, 0.5, 0.3, 4);
  const Keyframe k2 = texturedKeyframe(2, 3.0, 0.6, 8), k3 = texturedKeyframe(3, 3.5, 0.9, 12);

  // The first keyframe: nothing before it tells the motion.
  mapper.process(k0);
  EXPECT_EQ(mapper.store().keyframe(0).image.data, k0.image.data);
  EXPECT_EQ(mapper.rollingShutterNotRectified(), 1u);
  // The second: rectified with the motion since the first, and the first
  // too, since nothing has read its image yet.
  mapper.process(k1);
  const ImageU8 rectified1 = expected(k1, k0);
  EXPECT_NE(rectified1.data, k1.image.data);
  EXPECT_EQ(mapper.store().keyframe(1).image.data, rectified1.data);
  EXPECT_EQ(mapper.store().keyframe(0).image.data,
            rectifyRollingShutter(k0.image, k0.camera, cameraAngularVelocity(k0.camera, k1.camera, 0.5), readout).data);
  EXPECT_EQ(mapper.rollingShutterRectified(), 2u);
  EXPECT_EQ(mapper.rollingShutterNotRectified(), 0u);
  // 2.5 s later (> max_interval_s): used as it came, counted.
  mapper.process(k2);
  EXPECT_EQ(mapper.store().keyframe(2).image.data, k2.image.data);
  EXPECT_EQ(mapper.rollingShutterNotRectified(), 1u);
  // The next is rectified; keyframe 2 was read by its own estimate (its
  // sources were there), so it keeps its image.
  mapper.process(k3);
  EXPECT_EQ(mapper.store().keyframe(3).image.data, expected(k3, k2).data);
  EXPECT_EQ(mapper.store().keyframe(2).image.data, k2.image.data);
  EXPECT_EQ(mapper.rollingShutterRectified(), 3u);
  EXPECT_EQ(mapper.rollingShutterNotRectified(), 1u);
}

TEST(RollingShutter, InvalidOptionsAreRefusedWithTheirNames) {
  RollingShutterOptions options;
  options.readout_s = -0.01;
  options.max_interval_s = 0;
  const std::string problems = options.validate();
  EXPECT_NE(problems.find("readout_s must be in [0, 1]"), std::string::npos) << problems;
  EXPECT_NE(problems.find("max_interval_s must be positive"), std::string::npos) << problems;
  OnlineMapperOptions mapper;
  mapper.rolling_shutter.readout_s = NAN;
  EXPECT_NE(mapper.validate().find("rolling_shutter: readout_s"), std::string::npos) << mapper.validate();
}

}  // namespace
}  // namespace amhmvs
