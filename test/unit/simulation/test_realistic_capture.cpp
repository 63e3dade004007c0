// The realism model (realistic_capture.h): each effect does what its option
// says, measured on renders and draws; with no effect the render is the
// exact one, bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/simulation/realistic_capture.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"

namespace amhmvs {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// The room sequence these tests render: 5 frames at 128x96, 0.25 s apart
// (the path in 1 s: fast enough that 0.1 s moves the image by pixels).
struct Room {
  static constexpr int kFrames = 5, kWidth = 128, kHeight = 96;
  static constexpr double kPeriod = 0.25;
  SyntheticWorld world = makeIndoorRoomWorld(2);
  CameraTrajectory trajectory = smoothRoomTrajectory(kFrames, kWidth, kHeight, 2, kPeriod);

  RenderedView render(int frame, const RealismOptions& options, const FrameDisturbance& disturbance = {}) const {
    return renderRealisticView(world, trajectory, frame, options, disturbance);
  }
};

struct Stats {
  double mean = 0, sd = 0;
};
Stats stats(const std::vector<double>& values) {
  Stats s;
  for (double v : values) s.mean += v / values.size();
  for (double v : values) s.sd += (v - s.mean) * (v - s.mean) / (values.size() - 1);
  s.sd = std::sqrt(s.sd);
  return s;
}

double lagOneCorrelation(const std::vector<double>& values) {
  const Stats s = stats(values);
  double sum = 0;
  for (size_t i = 1; i < values.size(); ++i) sum += (values[i] - s.mean) * (values[i - 1] - s.mean);
  return sum / (values.size() - 1) / (s.sd * s.sd);
}

Eigen::Vector3d rotationVector(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd aa(rotation);
  return aa.angle() * aa.axis();
}

double bilinearGray(const ImageU8& gray, double u, double v) {
  const int x = static_cast<int>(std::floor(u)), y = static_cast<int>(std::floor(v));
  if (x < 0 || y < 0 || x + 1 >= gray.width || y + 1 >= gray.height) return NAN;
  const double a = u - x, b = v - y;
  return (1 - a) * (1 - b) * gray.at(x, y) + a * (1 - b) * gray.at(x + 1, y) + (1 - a) * b * gray.at(x, y + 1) +
         a * b * gray.at(x + 1, y + 1);
}

// Mean absolute grey difference between `from`'s pixels of rows [row_begin,
// row_end) and `target` sampled where their true points (from's depth, placed
// with from_camera) project into target_camera.
double reprojectionError(const RenderedView& from, const PinholeCamera& from_camera, int row_begin, int row_end,
                         const ImageU8& target, const PinholeCamera& target_camera) {
  const ImageU8 from_gray = toGray(from.image), target_gray = toGray(target);
  double sum = 0;
  long count = 0;
  for (int y = row_begin; y < row_end; ++y) {
    for (int x = 0; x < from.depth.width; ++x) {
      const double z = from.depth.at(x, y);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d world = from_camera.R.transpose() * (from_camera.backproject(x, y, z) - from_camera.t);
      const Eigen::Vector3d in_target = target_camera.toCamera(world);
      if (!(in_target.z() > 0)) continue;
      const Eigen::Vector2d p = target_camera.project(in_target);
      const double value = bilinearGray(target_gray, p.x(), p.y());
      if (std::isnan(value)) continue;
      sum += std::abs(value - from_gray.at(x, y));
      ++count;
    }
  }
  return sum / count;
}

// Of the candidate times, the one whose camera makes the reprojection error smallest.
double bestTime(const std::vector<double>& times, const std::function<double(double)>& error_at) {
  double best_time = NAN, best_error = INFINITY;
  for (double t : times) {
    const double e = error_at(t);
    if (e < best_error) best_error = e, best_time = t;
  }
  return best_time;
}

double gradientEnergy(const ImageU8& image) {
  const ImageU8 gray = toGray(image);
  double sum = 0;
  for (int y = 0; y + 1 < gray.height; ++y) {
    for (int x = 0; x + 1 < gray.width; ++x) {
      const double gx = gray.at(x + 1, y) - gray.at(x, y), gy = gray.at(x, y + 1) - gray.at(x, y);
      sum += gx * gx + gy * gy;
    }
  }
  return sum;
}

double meanOf(const ImageU8& image) {
  double sum = 0;
  for (uint8_t v : image.data) sum += v;
  return sum / image.data.size();
}

TEST(RealisticCapture, NoEffectIsThePlainRenderBitForBit) {
  const Room room;
  const std::vector<PinholeCamera> cameras = makeSmoothTrajectory(Room::kFrames, Room::kWidth, Room::kHeight, 2);
  RealismOptions none;
  none.seed = 77;                    // neither the seed...
  none.exposure_correlation = 0.3;   // ...nor an effect's shape is an effect
  none.motion_blur_samples = 3;
  const std::vector<FrameDisturbance> disturbances = drawFrameDisturbances(none, Room::kFrames, Room::kPeriod);
  for (int frame : {0, 3}) {
    const RenderedView plain = renderView(room.world, cameras[frame]);
    const RenderedView realistic = room.render(frame, none, disturbances[frame]);
    EXPECT_EQ(realistic.image.data, plain.image.data) << frame;
    EXPECT_EQ(0, std::memcmp(realistic.depth.data.data(), plain.depth.data.data(), plain.depth.data.size() * 4));
    EXPECT_EQ(0, std::memcmp(realistic.normal.data.data(), plain.normal.data.data(), plain.normal.data.size() * 4));
    const PinholeCamera tracked = trackedCamera(room.trajectory(frame, 0), disturbances[frame]);
    EXPECT_EQ(tracked.R, cameras[frame].R);
    EXPECT_EQ(tracked.t, cameras[frame].t);
  }
}

// Each axis of `field` over the draws is zero-mean noise of std dev `sigma`,
// independent from one frame to the next (jitter, not drift). With 4000
// draws the sample std dev is within 1.1 % (1 sigma) of the true one.
void expectWhiteNoise(const std::vector<FrameDisturbance>& draws, double sigma, const char* name,
                      const std::function<Eigen::Vector3d(const FrameDisturbance&)>& field) {
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    for (const FrameDisturbance& f : draws) values.push_back(field(f)[axis]);
    const Stats s = stats(values);
    EXPECT_NEAR(s.sd, sigma, sigma * 0.05) << name << ", axis " << axis;
    EXPECT_NEAR(s.mean, 0, 4 * sigma / std::sqrt(values.size())) << name << ", axis " << axis;
    EXPECT_LT(std::abs(lagOneCorrelation(values)), 0.07) << name << ", axis " << axis;
  }
}

TEST(RealisticCapture, PoseNoiseHasTheStatisticsOfTheOptions) {
  RealismOptions options;
  options.pose_noise_m = 0.02;
  options.pose_noise_deg = 0.5;
  const int frames = 4000;
  const std::vector<FrameDisturbance> d = drawFrameDisturbances(options, frames, 0.1);
  expectWhiteNoise(d, 0.02, "position", [](const FrameDisturbance& f) { return f.position_error; });
  expectWhiteNoise(d, 0.5, "rotation (deg)",
                   [](const FrameDisturbance& f) { return Eigen::Vector3d(rotationVector(f.rotation_error) * kRadToDeg); });
  // The written pose is the true one moved by exactly that error.
  const PinholeCamera truth = makeSmoothTrajectory(3, 64, 48, 1)[1];
  const PinholeCamera tracked = trackedCamera(truth, d[5]);
  EXPECT_LT((tracked.center() - truth.center() - d[5].position_error).norm(), 1e-12);
  EXPECT_LT((tracked.R.transpose() - d[5].rotation_error * truth.R.transpose()).norm(), 1e-12);
  EXPECT_EQ(tracked.validate(), "");
}

TEST(RealisticCapture, DriftIsARandomWalkThatGrowsWithTime) {
  RealismOptions options;
  options.pose_drift_m = 0.01;
  options.pose_drift_deg = 0.2;
  const double period = 0.5;
  const int frames = 21, sequences = 500;
  std::vector<double> early, late, late_deg;  // frame 5 (2.5 s) and 20 (10 s), every axis
  for (uint32_t seed = 1; seed <= sequences; ++seed) {
    options.seed = seed;
    const std::vector<FrameDisturbance> d = drawFrameDisturbances(options, frames, period);
    ASSERT_TRUE(d[0].position_error.isZero(0) && d[0].rotation_error.isIdentity(0));  // starts at the truth
    for (int axis = 0; axis < 3; ++axis) {
      early.push_back(d[5].position_error[axis]);
      late.push_back(d[20].position_error[axis]);
      late_deg.push_back(rotationVector(d[20].rotation_error)[axis] * kRadToDeg);
    }
  }
  // 1500 samples each: the std dev within 1.8 % (1 sigma); 10 % is 5 sigma.
  EXPECT_NEAR(stats(early).sd, 0.01 * std::sqrt(2.5), 0.1 * 0.01 * std::sqrt(2.5));
  EXPECT_NEAR(stats(late).sd, 0.01 * std::sqrt(10.0), 0.1 * 0.01 * std::sqrt(10.0));
  EXPECT_NEAR(stats(late_deg).sd, 0.2 * std::sqrt(10.0), 0.1 * 0.2 * std::sqrt(10.0));
  // A bias, not jitter: consecutive frames of one sequence differ by one step only.
  options.seed = 3;
  const std::vector<FrameDisturbance> d = drawFrameDisturbances(options, frames, period);
  double largest_step = 0;
  for (int i = 1; i < frames; ++i) {
    largest_step = std::max(largest_step, (d[i].position_error - d[i - 1].position_error).norm());
  }
  EXPECT_LT(largest_step, 5 * 0.01 * std::sqrt(period) * std::sqrt(3.0));
}

TEST(RealisticCapture, ExposureGainAndOffsetAreSmoothAndOfTheSetSize) {
  RealismOptions options;
  options.exposure_gain_sigma = 0.1;
  options.exposure_offset_sigma = 3;
  options.exposure_correlation = 0.8;
  const std::vector<FrameDisturbance> d = drawFrameDisturbances(options, 6000, 0.1);
  std::vector<double> log_gain, offset;
  for (const FrameDisturbance& f : d) {
    log_gain.push_back(std::log(f.gain));
    offset.push_back(f.offset);
  }
  // Correlated draws: about 670 independent ones; the std dev within 2.7 % (1 sigma).
  EXPECT_NEAR(stats(log_gain).sd, 0.1, 0.1 * 0.12);
  EXPECT_NEAR(stats(offset).sd, 3, 3 * 0.12);
  EXPECT_NEAR(lagOneCorrelation(log_gain), 0.8, 0.04);
  EXPECT_NEAR(lagOneCorrelation(offset), 0.8, 0.04);
}

TEST(RealisticCapture, GainAndOffsetChangeTheMeanIntensityByTheSetAmount) {
  const Room room;
  const RealismOptions options;  // the frame's gain and offset apply whatever drew them
  const RenderedView plain = room.render(1, RealismOptions());
  FrameDisturbance brighter;
  brighter.gain = 1.1;
  FrameDisturbance darker;
  darker.gain = 0.8;
  darker.offset = 10;
  const RenderedView bright = room.render(1, options, brighter), dark = room.render(1, options, darker);
  // Over the pixels that stay below 255 (the room's radiance is 30..225).
  double sum_plain = 0, sum_bright = 0, sum_dark = 0;
  long count = 0;
  for (size_t i = 0; i < plain.image.data.size(); ++i) {
    if (plain.image.data[i] > 225) continue;
    sum_plain += plain.image.data[i];
    sum_bright += bright.image.data[i];
    sum_dark += dark.image.data[i];
    ++count;
  }
  ASSERT_GT(count, Room::kWidth * Room::kHeight);  // of 3 channels per pixel
  EXPECT_NEAR(sum_bright / sum_plain, 1.1, 0.002);
  EXPECT_NEAR((sum_dark - 0.8 * sum_plain) / count, 10, 0.2);
  // Clipped to 255, never wrapped.
  FrameDisturbance blinding;
  blinding.gain = 3;
  const RenderedView white = room.render(1, options, blinding);
  EXPECT_GT(meanOf(white.image), 240);
}

TEST(RealisticCapture, SensorNoiseHasTheSetSigmaOnAFlatRegion) {
  // A flat grey wall (contrast 0: radiance 127.5 everywhere) filling the view.
  SyntheticWorld wall;
  wall.planes.push_back(makeTexturedQuad({-50, -50, 3}, {100, 0, 0}, {0, 100, 0}, 1, 0.1, 0.0));
  const std::vector<PinholeCamera> camera = {makeSidewaysCameras(1, 96, 64, 0.1, -1)[0]};
  const CameraTrajectory still = interpolatedTrajectory(camera, 1.0);
  RealismOptions options;
  options.noise_sigma = 2;
  options.shot_noise = 0.05;
  for (const double gain : {0.4, 1.6}) {
    FrameDisturbance exposure;
    exposure.gain = gain;
    const RenderedView view = renderRealisticView(wall, still, 0, options, exposure);
    std::vector<double> levels(view.image.data.begin(), view.image.data.end());
    const Stats s = stats(levels);
    const double level = gain * 127.5;
    // Read and shot noise, plus the quantisation's 1/12 level^2.
    const double expected = std::sqrt(2.0 * 2.0 + 0.05 * level + 1.0 / 12);
    SCOPED_TRACE("gain " + std::to_string(gain));
    EXPECT_NEAR(s.mean, level, 0.1);
    EXPECT_NEAR(s.sd, expected, 0.03 * expected);  // 18432 samples: 0.5 % (1 sigma)
  }
  // Deterministic per seed, another seed other noise.
  const RenderedView a = renderRealisticView(wall, still, 0, options, {});
  EXPECT_EQ(a.image.data, renderRealisticView(wall, still, 0, options, {}).image.data);
  options.seed = 2;
  EXPECT_NE(a.image.data, renderRealisticView(wall, still, 0, options, {}).image.data);
}

TEST(RealisticCapture, MotionBlurReducesGradientEnergyAndKeepsTheMidExposureDepth) {
  const Room room;
  const RenderedView sharp = room.render(2, RealismOptions());
  RealismOptions blur;
  blur.motion_blur_s = 0.05;
  const RenderedView blurred = room.render(2, blur);
  blur.motion_blur_s = 0.15;
  const RenderedView more = room.render(2, blur);
  // The image moves by this much during the exposures.
  const double motion = meanImageMotion(sharp.depth, room.trajectory(2, -0.075), room.trajectory(2, 0.075));
  EXPECT_GT(motion, 4.0);
  EXPECT_LT(gradientEnergy(blurred.image), 0.85 * gradientEnergy(sharp.image));
  EXPECT_LT(gradientEnergy(more.image), 0.8 * gradientEnergy(blurred.image));
  EXPECT_EQ(blurred.depth.data, sharp.depth.data);  // the mid-exposure pose's exact depth
  // The mean brightness stays (the blur only spreads it).
  EXPECT_NEAR(meanOf(more.image), meanOf(sharp.image), 2.0);
}

TEST(RealisticCapture, TimingOffsetMovesTheImageByTheFlowOfThatTime) {
  const Room room;
  RealismOptions late;
  late.time_offset_s = 0.1;
  const RenderedView stamp = room.render(2, RealismOptions());
  const RenderedView offset = room.render(2, late);
  // The truth written with the image is the camera at stamp + offset.
  const PinholeCamera at_offset = room.trajectory(2, 0.1);
  EXPECT_EQ(offset.camera.R, at_offset.R);
  EXPECT_EQ(offset.camera.t, at_offset.t);
  EXPECT_GT(meanImageMotion(stamp.depth, room.trajectory(2, 0), at_offset), 2.0);
  // Moving the stamp's pixels through their true depth into cameras of
  // candidate times: the offset image agrees best with the offset's camera.
  const std::vector<double> times = {0, 0.025, 0.05, 0.075, 0.1, 0.125, 0.15, 0.175, 0.2};
  const double best = bestTime(times, [&](double t) {
    return reprojectionError(stamp, stamp.camera, 0, Room::kHeight, offset.image, room.trajectory(2, t));
  });
  EXPECT_EQ(best, 0.1);
  const double error_at_offset = reprojectionError(stamp, stamp.camera, 0, Room::kHeight, offset.image, at_offset);
  const double error_at_stamp = reprojectionError(stamp, stamp.camera, 0, Room::kHeight, offset.image, stamp.camera);
  EXPECT_LT(error_at_offset, 0.5 * error_at_stamp) << error_at_offset << " vs " << error_at_stamp;
}

TEST(RealisticCapture, RollingShutterRowsAreConsistentWithTheirOwnPoses) {
  const Room room;
  RealismOptions shutter;
  shutter.rolling_shutter_s = 0.2;
  const RenderedView rolling = room.render(2, shutter);
  EXPECT_GT(meanImageMotion(rolling.depth, room.trajectory(2, -0.1), room.trajectory(2, 0.1)), 4.0);
  // Another frame, exact: the reference the rows are reprojected into.
  const RenderedView other = room.render(3, RealismOptions());
  const std::vector<double> times = {-0.125, -0.1, -0.075, -0.05, -0.025, 0, 0.025, 0.05, 0.075, 0.1, 0.125};
  const int band = Room::kHeight / 8;
  auto bandError = [&](int row_begin, double t) {
    return reprojectionError(rolling, room.trajectory(2, t), row_begin, row_begin + band, other.image, other.camera);
  };
  // Top rows are read out first (0.1 s before the middle row), bottom rows last.
  const double top = bestTime(times, [&](double t) { return bandError(0, t); });
  const double bottom = bestTime(times, [&](double t) { return bandError(Room::kHeight - band, t); });
  EXPECT_GE(top, -0.1);
  EXPECT_LE(top, -0.075);
  EXPECT_GE(bottom, 0.075);
  EXPECT_LE(bottom, 0.1);
  // The frame's single pose (the stamp) fits neither end.
  EXPECT_GT(bandError(0, 0), 1.5 * bandError(0, top));
  EXPECT_GT(bandError(Room::kHeight - band, 0), 1.5 * bandError(Room::kHeight - band, bottom));
  // The truth written with the frame is the middle row's pose (at the stamp here).
  EXPECT_EQ(rolling.camera.t, room.trajectory(2, 0).t);
}

TEST(RealisticCapture, InterpolatedPosesMoveAlongTheShortestRotation) {
  const std::vector<PinholeCamera> cams = makeSidewaysCameras(3, 64, 48, 0.2, 4.0);
  const CameraTrajectory path = interpolatedTrajectory(cams, 0.5);
  EXPECT_EQ(path(1, 0).t, cams[1].t);  // a frame's own pose, exactly
  const PinholeCamera half = path(0, 0.25);
  EXPECT_LT((half.center() - 0.5 * (cams[0].center() + cams[1].center())).norm(), 1e-12);
  const double full = Eigen::AngleAxisd(cams[1].R * cams[0].R.transpose()).angle();
  EXPECT_NEAR(Eigen::AngleAxisd(half.R * cams[0].R.transpose()).angle(), full / 2, 1e-12);
  EXPECT_EQ(half.validate(), "");
  const PinholeCamera one = interpolateCamera(cams[0], cams[1], 1.0);
  EXPECT_LT((one.R - cams[1].R).norm() + (one.t - cams[1].t).norm(), 1e-12);
  // The smooth room path: its frames exactly, and in time between them.
  const CameraTrajectory room = smoothRoomTrajectory(4, 64, 48, 5, 0.5);
  const std::vector<PinholeCamera> frames = makeSmoothTrajectory(4, 64, 48, 5);
  EXPECT_EQ(room(2, 0).t, frames[2].t);
  EXPECT_EQ(room(1, 0.5).t, frames[2].t);  // frame 1 + one period is frame 2
}

}  // namespace
}  // namespace amhmvs
