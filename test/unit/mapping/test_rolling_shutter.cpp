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

// A world point seen by a turning rolling-shutter camera: found in an image
// rectified with a wrong turn rate, rectifiedAgain() moves it to where the
// image rectified with the true rate shows it, the global shutter's pixel.
TEST(RollingShutter, FeaturesMoveToWhereTheImageRectifiedAgainShowsThem) {
  const PinholeCamera camera = test::centredCamera(320, 240, 256);
  const Eigen::Vector3d truth(0.05, 0.2, 0.03), chord(0.04, 0.17, 0.05);  // rad/s, camera frame
  constexpr double kReadout = 0.025;
  const auto rowTime = [&](double row) { return kReadout * (row / (camera.height - 1) - 0.5); };
  const auto rotation = [](const Eigen::Vector3d& velocity, double seconds) {
    return Eigen::AngleAxisd(velocity.norm() * seconds, velocity.normalized()).toRotationMatrix();
  };
  const auto pixelOf = [&](const Eigen::Vector3d& ray) { return camera.project(ray); };
  double worst_moved = 0, worst_as_found = 0;
  for (const Eigen::Vector3d point : {Eigen::Vector3d(-1.2, -0.9, 2.0), Eigen::Vector3d(0.3, 0.1, 3.0),
                                      Eigen::Vector3d(1.1, 0.8, 2.5), Eigen::Vector3d(-0.4, 0.7, 4.0)}) {
    // The rolling shutter sees the point (middle row's camera frame) in the
    // row exposed while the camera had turned by w t(row): a fixed point.
    double row = pixelOf(point).y();
    Eigen::Vector3d seen = point;
    for (int i = 0; i < 50; ++i) {
      seen = rotation(truth, rowTime(row)).transpose() * point;
      row = pixelOf(seen).y();
    }
    // Rectified with the chord, the feature is where that rectification shows the ray.
    const Eigen::Vector2d found = pixelOf(rotation(chord, rowTime(row)) * seen);
    const Eigen::Vector2d moved = rectifiedAgain(found, camera, chord, truth, kReadout);
    worst_as_found = std::max(worst_as_found, (found - pixelOf(point)).norm());
    worst_moved = std::max(worst_moved, (moved - pixelOf(point)).norm());
    // The same rate: the pixel as it is; and back again (the row's fixed
    // point, two iterations as the rectification's, leaves ~1e-6 px).
    EXPECT_LT((rectifiedAgain(found, camera, chord, chord, kReadout) - found).norm(), 1e-5);
    EXPECT_LT((rectifiedAgain(moved, camera, truth, chord, kReadout) - found).norm(), 1e-5);
  }
  std::printf("global-shutter pixel to the feature: rectified with the chord %.4f px, moved %.6f px\n", worst_as_found,
              worst_moved);
  // Measured: 0.0959 px (the chord 2.1 deg/s off), moved 0.000001 px.
  EXPECT_GT(worst_as_found, 0.05);
  EXPECT_LT(worst_moved, 1e-5);
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

// With the tracker's velocity a keyframe needs nothing from the one before:
// its own turn rate rectifies it, and its linear velocity becomes the motion
// the matching cost sees each row from (unless translation is off).
TEST(RollingShutter, OnlineMapperUsesTheTrackersVelocityWhenGiven) {
  OnlineMapperOptions options = test::wallOptions();
  options.rolling_shutter.readout_s = 0.05;
  options.rolling_shutter.use_tracker_velocity = true;
  OnlineMapper mapper(options, test::wallDepth);
  Keyframe k0 = texturedKeyframe(0, 0.0, 0.0, 0);
  CameraVelocity velocity;
  velocity.angular = Eigen::Vector3d(0.2, -0.4, 0.1);
  velocity.linear = Eigen::Vector3d(0.3, 0, 0.1);
  k0.velocity = velocity;
  mapper.process(k0);
  EXPECT_EQ(mapper.store().keyframe(0).image.data,
            rectifyRollingShutter(k0.image, k0.camera, velocity.angular, 0.05).data);
  EXPECT_EQ(mapper.rollingShutterRectified(), 1u);
  EXPECT_EQ(mapper.rollingShutterNotRectified(), 0u);
  EXPECT_EQ(mapper.rollingShutterFromTrackerVelocity(), 1u);
  EXPECT_EQ(mapper.store().entry(0).motion.velocity, velocity.linear);
  EXPECT_EQ(mapper.store().entry(0).motion.readout_s, 0.05);
  // A keyframe without one: rectified from the poses, rotation only.
  mapper.process(texturedKeyframe(1, 0.5, 0.3, 4));
  EXPECT_FALSE(mapper.store().entry(1).motion.rolling());
  EXPECT_EQ(mapper.rollingShutterRectified(), 2u);
  EXPECT_EQ(mapper.rollingShutterFromTrackerVelocity(), 1u);
  // Translation off: the turn is still taken from the velocity, no motion kept.
  options.rolling_shutter.translation = false;
  OnlineMapper rotation_only(options, test::wallDepth);
  rotation_only.process(k0);
  EXPECT_EQ(rotation_only.store().keyframe(0).image.data, mapper.store().keyframe(0).image.data);
  EXPECT_FALSE(rotation_only.store().entry(0).motion.rolling());
  // Not asked for (the default): the velocity is ignored, the first keyframe waits for the second's motion.
  options.rolling_shutter.use_tracker_velocity = false;
  OnlineMapper ignoring(options, test::wallDepth);
  ignoring.process(k0);
  EXPECT_EQ(ignoring.store().keyframe(0).image.data, k0.image.data);
  EXPECT_EQ(ignoring.rollingShutterNotRectified(), 1u);
  // A velocity that is not finite is refused with the keyframe.
  Keyframe bad = texturedKeyframe(2, 1.0, 0.6, 8);
  bad.velocity = velocity;
  bad.velocity->linear.y() = NAN;
  EXPECT_EQ(bad.validate(), "velocity is not finite");
}

TEST(RollingShutter, InvalidOptionsAreRefusedWithTheirNames) {
  RollingShutterOptions options;
  options.readout_s = -0.01;
  options.max_interval_s = 0;
  options.tracker_velocity_sigma_rad_s = -0.05;
  options.tracker_velocity_sigma_m_s = INFINITY;
  const std::string problems = options.validate();
  EXPECT_NE(problems.find("readout_s must be in [0, 1]"), std::string::npos) << problems;
  EXPECT_NE(problems.find("max_interval_s must be positive"), std::string::npos) << problems;
  EXPECT_NE(problems.find("tracker_velocity_sigma_rad_s must be >= 0 and finite, got -0.05"), std::string::npos)
      << problems;
  EXPECT_NE(problems.find("tracker_velocity_sigma_m_s must be >= 0 and finite, got inf"), std::string::npos)
      << problems;
  OnlineMapperOptions mapper;
  mapper.rolling_shutter.readout_s = NAN;
  EXPECT_NE(mapper.validate().find("rolling_shutter: readout_s"), std::string::npos) << mapper.validate();
}

}  // namespace
}  // namespace amhmvs
