#include "amhmvs_mapping/simulation/realistic_capture.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/random.h"

namespace amhmvs {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

// Independent streams of random draws.
enum Stream : uint32_t {
  kPoseNoisePosition = 1,
  kPoseNoiseRotation,
  kDriftPosition,
  kDriftRotation,
  kGain,
  kOffset,
  kPixelNoise,
};

// Uniform in (0, 1), a pure function of (seed, stream, index, draw): no state,
// so pixels can be drawn in any order on any number of threads.
double uniformDraw(uint32_t seed, Stream stream, uint64_t index, uint32_t draw) {
  const uint32_t key = mvs::mixBits((static_cast<uint64_t>(seed) << 32) | stream);
  const uint32_t bits =
      mvs::mixBits(((static_cast<uint64_t>(key) << 32) | draw) ^ (index * 0x9E3779B97F4A7C15ull));
  return (bits + 0.5) * (1.0 / 4294967296.0);
}

// Standard normal (Box-Muller).
double gaussianDraw(uint32_t seed, Stream stream, uint64_t index) {
  const double u1 = uniformDraw(seed, stream, index, 0), u2 = uniformDraw(seed, stream, index, 1);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

// Three standard normals for frame `frame` (one per axis).
Eigen::Vector3d gaussianVector(uint32_t seed, Stream stream, int frame) {
  Eigen::Vector3d v;
  for (int axis = 0; axis < 3; ++axis) v[axis] = gaussianDraw(seed, stream, 3ull * frame + axis);
  return v;
}

Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

void setCameraToWorld(const Eigen::Matrix3d& camera_to_world, const Eigen::Vector3d& centre, PinholeCamera* camera) {
  camera->R = camera_to_world.transpose();
  camera->t = -camera->R * centre;
}

void requireValid(const RealismOptions& options) {
  const std::string why = options.check();
  if (!why.empty()) throw InputError("invalid realism options:\n" + why);
}

void requirePeriod(double frame_period_s) {
  if (!(frame_period_s > 0 && frame_period_s <= 3600)) {
    throw InputError("frame period must be in (0, 3600] seconds, got " + std::to_string(frame_period_s));
  }
}

}  // namespace

PinholeCamera interpolateCamera(const PinholeCamera& a, const PinholeCamera& b, double fraction) {
  const Eigen::Quaterniond qa(Eigen::Matrix3d(a.R.transpose())), qb(Eigen::Matrix3d(b.R.transpose()));
  const Eigen::Quaterniond q = qa.slerp(fraction, qb).normalized();
  PinholeCamera out = a;
  setCameraToWorld(q.toRotationMatrix(), (1 - fraction) * a.center() + fraction * b.center(), &out);
  return out;
}

CameraTrajectory interpolatedTrajectory(std::vector<PinholeCamera> cameras, double frame_period_s) {
  requirePeriod(frame_period_s);
  if (cameras.empty()) throw InputError("interpolatedTrajectory: no cameras");
  return [cameras = std::move(cameras), frame_period_s](int frame, double seconds) {
    if (seconds == 0 || cameras.size() == 1) return cameras.at(frame);
    const double position = frame + seconds / frame_period_s;
    const int last_segment = static_cast<int>(cameras.size()) - 2;
    const int segment = std::clamp(static_cast<int>(std::floor(position)), 0, last_segment);
    return interpolateCamera(cameras[segment], cameras[segment + 1], position - segment);
  };
}

CameraTrajectory smoothRoomTrajectory(int count, int width, int height, uint32_t seed, double frame_period_s) {
  requirePeriod(frame_period_s);
  makeSmoothTrajectory(count, width, height, seed);  // refuses bad counts and sizes here
  return [=](int frame, double seconds) {
    // As makeSmoothTrajectory computes s, so that seconds == 0 gives its view.
    const double position = frame + seconds / frame_period_s;
    return smoothTrajectoryCamera(count > 1 ? position / (count - 1) : 0.0, width, height, seed);
  };
}

std::vector<FrameDisturbance> drawFrameDisturbances(const RealismOptions& options, int frames,
                                                    double frame_period_s) {
  requireValid(options);
  requirePeriod(frame_period_s);
  const uint32_t seed = options.seed;
  const double drift_step = std::sqrt(frame_period_s);
  const double rho = options.exposure_correlation, innovation = std::sqrt(1 - rho * rho);
  std::vector<FrameDisturbance> out(std::max(frames, 0));
  Eigen::Vector3d drift_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d drift_rotation = Eigen::Matrix3d::Identity();
  double gain_state = 0, offset_state = 0;
  for (int i = 0; i < frames; ++i) {
    FrameDisturbance& d = out[i];
    if (i > 0 && options.pose_drift_m > 0) {
      drift_position += options.pose_drift_m * drift_step * gaussianVector(seed, kDriftPosition, i);
    }
    if (i > 0 && options.pose_drift_deg > 0) {
      drift_rotation = rotationFromVector(options.pose_drift_deg * kDegree * drift_step *
                                          gaussianVector(seed, kDriftRotation, i)) *
                       drift_rotation;
    }
    d.position_error = drift_position;
    if (options.pose_noise_m > 0) d.position_error += options.pose_noise_m * gaussianVector(seed, kPoseNoisePosition, i);
    d.rotation_error = drift_rotation;
    if (options.pose_noise_deg > 0) {
      d.rotation_error =
          rotationFromVector(options.pose_noise_deg * kDegree * gaussianVector(seed, kPoseNoiseRotation, i)) *
          d.rotation_error;
    }
    // Stationary AR(1): the first state is a plain draw.
    const double gain_draw = gaussianDraw(seed, kGain, i), offset_draw = gaussianDraw(seed, kOffset, i);
    gain_state = i == 0 ? gain_draw : rho * gain_state + innovation * gain_draw;
    offset_state = i == 0 ? offset_draw : rho * offset_state + innovation * offset_draw;
    if (options.exposure_gain_sigma > 0) d.gain = std::exp(options.exposure_gain_sigma * gain_state);
    if (options.exposure_offset_sigma > 0) d.offset = options.exposure_offset_sigma * offset_state;
  }
  return out;
}

PinholeCamera trackedCamera(const PinholeCamera& truth, const FrameDisturbance& disturbance) {
  if (disturbance.position_error.isZero(0) && disturbance.rotation_error.isIdentity(0)) return truth;
  PinholeCamera out = truth;
  setCameraToWorld(disturbance.rotation_error * truth.R.transpose(), truth.center() + disturbance.position_error,
                   &out);
  return out;
}

uint8_t sensorLevel(double radiance, const FrameDisturbance& disturbance, const RealismOptions& options, int frame,
                    int x, int y, int channel) {
  double level = disturbance.gain * radiance + disturbance.offset;
  if (options.noise_sigma > 0 || options.shot_noise > 0) {
    const double variance = options.noise_sigma * options.noise_sigma + options.shot_noise * std::max(0.0, level);
    // Pixel coordinates are below 2^14 (image sides up to 8192).
    const uint64_t index = (((static_cast<uint64_t>(frame) << 14 | y) << 14 | x) << 2) | channel;
    level += std::sqrt(variance) * gaussianDraw(options.seed, kPixelNoise, index);
  }
  return radianceToByte(level);
}

RowExposure rowExposure(const CameraTrajectory& trajectory, int frame, int row, int height,
                        const RealismOptions& options) {
  const double readout_fraction = height > 1 ? static_cast<double>(row) / (height - 1) - 0.5 : 0.0;
  const double row_time = options.time_offset_s + options.rolling_shutter_s * readout_fraction;
  RowExposure exposure{trajectory(frame, row_time), {}};
  if (options.motion_blur_s > 0) {
    const int samples = options.motion_blur_samples;
    for (int k = 0; k < samples; ++k) {
      exposure.samples.push_back(trajectory(frame, row_time + options.motion_blur_s * ((k + 0.5) / samples - 0.5)));
    }
  }
  return exposure;
}

RenderedView renderRealisticView(const SyntheticWorld& world, const CameraTrajectory& trajectory, int frame,
                                 const RealismOptions& options, const FrameDisturbance& disturbance,
                                 int supersampling) {
  requireValid(options);
  const PinholeCamera capture = trajectory(frame, options.time_offset_s);
  return renderViewByRows(
      world, capture,
      [&](int row) { return rowExposure(trajectory, frame, row, capture.height, options); }, supersampling,
      [&](double radiance, int x, int y, int channel) {
        return sensorLevel(radiance, disturbance, options, frame, x, y, channel);
      });
}

double meanImageMotion(const ImageF& depth, const PinholeCamera& from, const PinholeCamera& to) {
  double sum = 0;
  long count = 0;
  for (int y = 0; y < depth.height; ++y) {
    for (int x = 0; x < depth.width; ++x) {
      const double z = depth.at(x, y);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d world_point = from.R.transpose() * (from.backproject(x, y, z) - from.t);
      const Eigen::Vector3d in_to = to.toCamera(world_point);
      if (!(in_to.z() > 0)) continue;
      sum += (to.project(in_to) - Eigen::Vector2d(x, y)).norm();
      ++count;
    }
  }
  return count > 0 ? sum / count : NAN;
}

}  // namespace amhmvs
