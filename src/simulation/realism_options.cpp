#include "amhmvs_mapping/simulation/realism_options.h"

#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/option_field.h"

namespace amhmvs {

bool RealismOptions::any() const {
  return pose_noise_m != 0 || pose_noise_deg != 0 || pose_drift_m != 0 || pose_drift_deg != 0 ||
         time_offset_s != 0 || rolling_shutter_s != 0 || motion_blur_s != 0 || exposure_gain_sigma != 0 ||
         exposure_offset_sigma != 0 || noise_sigma != 0 || shot_noise != 0;
}

std::string RealismOptions::check() const {
  std::ostringstream why;
  // NaN fails every comparison, so "!(x >= lo)" refuses it too.
  auto range = [&why](const char* name, double value, double lo, double hi, const char* meaning) {
    if (!(value >= lo && value <= hi)) why << name << " must be " << meaning << ", got " << value << "\n";
  };
  range("pose_noise_m", pose_noise_m, 0, 1, "in [0, 1] metres");
  range("pose_noise_deg", pose_noise_deg, 0, 45, "in [0, 45] degrees");
  range("pose_drift_m", pose_drift_m, 0, 1, "in [0, 1] m/sqrt(s)");
  range("pose_drift_deg", pose_drift_deg, 0, 45, "in [0, 45] deg/sqrt(s)");
  range("time_offset_s", time_offset_s, -1, 1, "in [-1, 1] seconds");
  range("rolling_shutter_s", rolling_shutter_s, 0, 1, "in [0, 1] seconds");
  range("motion_blur_s", motion_blur_s, 0, 1, "in [0, 1] seconds");
  if (!(motion_blur_samples >= 1 && motion_blur_samples <= 64)) {
    why << "motion_blur_samples must be in 1..64, got " << motion_blur_samples << "\n";
  }
  range("exposure_gain_sigma", exposure_gain_sigma, 0, 2, "in [0, 2] (std dev of the log gain)");
  range("exposure_offset_sigma", exposure_offset_sigma, 0, 255, "in [0, 255] levels");
  if (!(exposure_correlation >= 0 && exposure_correlation < 1)) {
    why << "exposure_correlation must be in [0, 1), got " << exposure_correlation << "\n";
  }
  range("noise_sigma", noise_sigma, 0, 255, "in [0, 255] levels");
  range("shot_noise", shot_noise, 0, 255, "in [0, 255] levels^2 per level");
  return why.str();
}

RealismOptions realismProfile(const std::string& name) {
  RealismOptions options;
  if (name == "none") return options;
  if (name != "default") throw InputError("realism profile '" + name + "' is not one of none, default");
  // A handheld camera behind a visual-inertial tracker (README, amhmvs_synthetic).
  options.pose_noise_m = 0.01;
  options.pose_noise_deg = 0.3;
  options.pose_drift_m = 0.005;
  options.pose_drift_deg = 0.1;
  options.time_offset_s = 0.008;
  options.rolling_shutter_s = 0.025;
  options.motion_blur_s = 0.08;
  options.exposure_gain_sigma = 0.08;
  options.exposure_offset_sigma = 2;
  options.noise_sigma = 1.5;
  options.shot_noise = 0.02;
  return options;
}

const std::vector<RealismOptionInfo>& realismOptionTable() {
  using O = RealismOptions;
  static const std::vector<RealismOptionInfo> table = {
      numberField("pose_noise_m", &O::pose_noise_m, "written poses: per-frame position jitter, std dev per axis, m"),
      numberField("pose_noise_deg", &O::pose_noise_deg,
                  "written poses: per-frame rotation jitter, std dev per axis, degrees"),
      numberField("pose_drift_m", &O::pose_drift_m,
                  "written poses: random-walk position bias, std dev per axis after 1 s, m/sqrt(s)"),
      numberField("pose_drift_deg", &O::pose_drift_deg,
                  "written poses: random-walk rotation bias, std dev per axis after 1 s, deg/sqrt(s)"),
      numberField("time_offset_s", &O::time_offset_s, "image taken this long after its pose's stamp, s"),
      numberField("rolling_shutter_s", &O::rolling_shutter_s,
                  "readout time from the first to the last row (middle row at the stamp + offset), s"),
      numberField("motion_blur_s", &O::motion_blur_s, "exposure time per row (renders averaged over it), s"),
      numberField("motion_blur_samples", &O::motion_blur_samples, "renders averaged over the exposure"),
      numberField("exposure_gain_sigma", &O::exposure_gain_sigma, "per-frame gain: std dev of its log"),
      numberField("exposure_offset_sigma", &O::exposure_offset_sigma, "per-frame offset: std dev, levels"),
      numberField("exposure_correlation", &O::exposure_correlation,
                  "gain and offset correlation from one frame to the next, [0, 1)"),
      numberField("noise_sigma", &O::noise_sigma, "read noise std dev, levels (images quantised to 8 bit)"),
      numberField("shot_noise", &O::shot_noise, "shot noise: variance added per level of intensity, levels^2"),
      numberField("realism_seed", &O::seed, "seed of the realism's random draws (default: --seed)"),
  };
  return table;
}

}  // namespace amhmvs
