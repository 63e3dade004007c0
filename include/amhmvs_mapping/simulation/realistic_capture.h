// Synthetic frames as a real camera behind a real tracker delivers them
// (RealismOptions): each image row is rendered at the camera's true pose at
// its own time (timing offset, rolling shutter) and averaged over the
// exposure (motion blur), then the sensor applies the frame's gain and offset
// and adds read and shot noise; the tracker's written pose is the true pose
// at the frame's stamp plus noise and a drifting bias. The ground truth
// (depth of what each pixel saw, the true poses) stays exact.
//
// Times: frame i's stamp is i * frame_period_s; a row is taken at the stamp
// + time_offset_s + rolling_shutter_s * (y / (height - 1) - 0.5), so the
// middle row is at the stamp + the offset, and is exposed for motion_blur_s
// centred on that time.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/simulation/realism_options.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"

namespace amhmvs {

// A camera moving in time: the true camera of frame `frame` at `seconds`
// after that frame's stamp (negative: before). seconds == 0 gives the frame's
// own camera exactly. Called from one thread at a time.
using CameraTrajectory = std::function<PinholeCamera(int frame, double seconds)>;

// The pose a fraction of the way from a (0) to b (1), any fraction
// (extrapolated outside [0, 1]): rotation by slerp, centre linear.
// Intrinsics and size of a.
PinholeCamera interpolateCamera(const PinholeCamera& a, const PinholeCamera& b, double fraction);

// Poses between given cameras, frame_period_s apart (interpolateCamera;
// before the first and after the last the end segment is extended).
CameraTrajectory interpolatedTrajectory(std::vector<PinholeCamera> cameras, double frame_period_s);

// makeSmoothTrajectory(count, width, height, seed) in time, frame i at
// i * frame_period_s: the path itself between and beyond the frames.
CameraTrajectory smoothRoomTrajectory(int count, int width, int height, uint32_t seed, double frame_period_s);

// One frame's tracker error and exposure (drawFrameDisturbances).
struct FrameDisturbance {
  // Written camera-to-world pose: rotation rotation_error * R_true (world
  // axes, about the camera centre), centre c_true + position_error (world).
  Eigen::Vector3d position_error = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation_error = Eigen::Matrix3d::Identity();
  double gain = 1;    // level = gain * radiance + offset, before noise
  double offset = 0;  // levels
};

// The disturbances of frames 0..frames-1: pose noise
// (independent per frame) plus drift (a random walk from zero at frame 0, increments of std dev
// pose_drift * sqrt(frame_period_s) per axis); gain exp(sigma z) and offset
// sigma z' with z, z' stationary unit-variance AR(1) processes of
// correlation exposure_correlation. A pure function of its arguments (seed
// in the options). Throws InputError for invalid options or period.
std::vector<FrameDisturbance> drawFrameDisturbances(const RealismOptions& options, int frames,
                                                    double frame_period_s);

// The camera the tracker reports: `truth` moved by the disturbance's pose
// error; `truth` itself, bit for bit, when the error is zero.
PinholeCamera trackedCamera(const PinholeCamera& truth, const FrameDisturbance& disturbance);

// The sensor's 8-bit level of a pixel channel of mean radiance `radiance`:
// gain * radiance + offset, plus Gaussian noise of variance noise_sigma^2 +
// shot_noise * max(0, that level), rounded and clipped to 0..255. The noise
// is a pure function of (seed, frame, x, y, channel). With gain 1, offset 0
// and no noise: radianceToByte(radiance).
uint8_t sensorLevel(double radiance, const FrameDisturbance& disturbance, const RealismOptions& options,
                    int frame, int x, int y, int channel);

// The poses that row `row` of a frame of `height` rows is exposed from:
// mid exposure at the row's time, and motion_blur_samples times evenly
// spread over the exposure (none without motion blur).
RowExposure rowExposure(const CameraTrajectory& trajectory, int frame, int row, int height,
                        const RealismOptions& options);

// Frame `frame` as the camera takes it. `camera` of the result is the true
// camera at the middle row's time (stamp + time_offset_s); `depth` and
// `normal` are exact for what each pixel saw (in its row's camera at mid
// exposure, which for a pose-independent z-depth per pixel is what an
// estimate in the written camera is compared with). With options.any()
// false this is renderView(world, trajectory(frame, 0)) bit for bit.
RenderedView renderRealisticView(const SyntheticWorld& world, const CameraTrajectory& trajectory, int frame,
                                 const RealismOptions& options, const FrameDisturbance& disturbance,
                                 int supersampling = 3);

// Mean image motion, in pixels, of the pixels with finite depth (z-depth in
// `from`) when the camera moves from `from` to `to` (same intrinsics); NaN
// when no pixel has depth in front of both.
double meanImageMotion(const ImageF& depth, const PinholeCamera& from, const PinholeCamera& to);

}  // namespace amhmvs
