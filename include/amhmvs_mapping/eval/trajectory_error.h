// How far a tracker's trajectory is from a reference one, reported the way
// trajectory benchmarks do (TUM RGB-D's absolute and relative pose errors),
// plus what the error means for stereo: how many pixels the relative pose of
// a keyframe pair is off where the pair's depth maps are matched.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"

namespace amhmvs {

struct TrajectoryErrorOptions {
  // The pairs of the relative errors: consecutive keyframes as the mapper
  // picks them on the reference trajectory (motion test only: sharpness is
  // not judged here).
  KeyframePickerOptions keyframes;
  int pixel_stride = 8;  // the misalignment samples every Nth pixel of each row and column

  TrajectoryErrorOptions() { keyframes.min_relative_sharpness = 0; }
  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

struct TrajectoryError {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  size_t poses = 0;
  // Absolute trajectory error: camera centres after the rigid motion that
  // best carries the estimate onto the reference (no scale: RGB-D is metric).
  double ate_rmse_m = kNaN, ate_median_m = kNaN, ate_max_m = kNaN;
  // Relative pose error over the keyframe pairs.
  size_t keyframe_pairs = 0;
  double rpe_translation_rmse_m = kNaN, rpe_rotation_rmse_deg = kNaN;
  double rpe_translation_max_m = kNaN, rpe_rotation_max_deg = kNaN;
  // Each pair's median distance, in pixels of the second keyframe, between
  // where a sampled pixel of the first lands with the reference and with
  // the estimated relative pose (at the first's depth); then the median, 90th
  // percentile and maximum of those over the pairs with depth.
  size_t misalignment_pairs = 0;
  double misalignment_median_px = kNaN, misalignment_p90_px = kNaN, misalignment_max_px = kNaN;
  std::vector<size_t> keyframes;  // indices of the reference's keyframes
};

// `estimated` and `reference`: camera-to-world poses of the same frames in
// order. `depth(i)`: frame i's z-depth (NaN or <= 0: none) in `camera` (the
// frame whose poses these are; its pose is not used); an empty image leaves
// the pairs starting at frame i out of the misalignment. Throws InputError
// for sizes that differ, fewer than 2 poses or invalid options.
TrajectoryError trajectoryError(const std::vector<Eigen::Isometry3d>& estimated,
                                const std::vector<Eigen::Isometry3d>& reference, const PinholeCamera& camera,
                                const std::function<ImageF(size_t)>& depth,
                                const TrajectoryErrorOptions& options = TrajectoryErrorOptions());

// The report as one JSON object (lengths in metres, angles in degrees).
std::string trajectoryErrorJson(const TrajectoryError& error);

}  // namespace amhmvs
