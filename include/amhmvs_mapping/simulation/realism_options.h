// What a synthetic sequence's realism mode adds to the exact render: the
// errors of a real tracker and camera (pose noise and drift, a timing offset
// between image and pose, rolling shutter, motion blur, exposure changes,
// sensor noise). Every field is 0 ("none": the exact render) by default;
// realismProfile("default") is a handheld camera behind a VIO tracker. The
// ground truth written beside a realistic sequence stays exact.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/option_field.h"

namespace amhmvs {

struct RealismOptions {
  // --- Tracker poses: the WRITTEN poses only; images are taken at the true ones ---
  // Rotation errors turn the camera about its own centre (world axes).
  double pose_noise_m = 0;    // per-frame jitter: std dev per world axis of the position, metres
  double pose_noise_deg = 0;  // per-frame jitter: std dev per axis of the rotation vector, degrees
  double pose_drift_m = 0;    // random-walk bias of the position: std dev per axis after 1 s, m/sqrt(s)
  double pose_drift_deg = 0;  // random-walk bias of the rotation: std dev per axis after 1 s, deg/sqrt(s)

  // --- Timing (seconds; a row's time is the frame's stamp + these) ---
  double time_offset_s = 0;      // the image is taken this much after its pose's stamp
  double rolling_shutter_s = 0;  // readout from the first to the last row; the middle row is at the offset
  double motion_blur_s = 0;      // exposure time of each row, centred on the row's time
  int motion_blur_samples = 8;   // renders averaged over the exposure (when motion_blur_s > 0)

  // --- Photometry (grey levels 0..255, per frame smooth over time) ---
  double exposure_gain_sigma = 0;    // std dev of the log of each frame's gain
  double exposure_offset_sigma = 0;  // std dev of each frame's offset, levels
  double exposure_correlation = 0.8; // of gain and offset from one frame to the next, [0, 1)
  double noise_sigma = 0;            // read noise, std dev in levels
  double shot_noise = 0;             // shot noise: variance grows by this many levels^2 per level

  uint32_t seed = 1;  // all random draws are a pure function of it (and frame, pixel)

  // True when any effect is on; false means the exact render.
  bool any() const;
  // Empty when valid; otherwise one line per problem, naming the option.
  std::string check() const;
};

// "none" (all effects off) or "default" (see realism_options.cpp and the
// README: ~1 cm / 0.3 deg pose noise, 8 ms offset, 25 ms rolling shutter,
// ...). Throws InputError for another name.
RealismOptions realismProfile(const std::string& name);

// The options by text (name without --, meaning, accessors): the single list
// for the tool's parser and --help.
using RealismOptionInfo = OptionField<RealismOptions>;
const std::vector<RealismOptionInfo>& realismOptionTable();

}  // namespace amhmvs
