// RealismOptions: the profiles, the checks (every bad value named) and the
// option table the tool parses with.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/simulation/realism_options.h"
#include "amhmvs_mapping/simulation/realistic_capture.h"

namespace amhmvs {
namespace {

void setOption(RealismOptions& options, const std::string& name, const std::string& value) {
  for (const RealismOptionInfo& info : realismOptionTable()) {
    if (info.name == name) return info.set(options, value);
  }
  FAIL() << "no realism option " << name;
}

TEST(RealismOptions, NoneIsTheExactRenderDefaultTurnsEveryEffectOn) {
  EXPECT_FALSE(RealismOptions().any());
  EXPECT_FALSE(realismProfile("none").any());
  const RealismOptions profile = realismProfile("default");
  EXPECT_EQ(profile.check(), "");
  // Each effect of the documented profile (README) is on.
  EXPECT_EQ(profile.pose_noise_m, 0.01);
  EXPECT_EQ(profile.pose_noise_deg, 0.3);
  EXPECT_GT(profile.pose_drift_m, 0);
  EXPECT_GT(profile.pose_drift_deg, 0);
  EXPECT_EQ(profile.time_offset_s, 0.008);
  EXPECT_EQ(profile.rolling_shutter_s, 0.025);
  EXPECT_GT(profile.motion_blur_s, 0);
  EXPECT_GT(profile.exposure_gain_sigma, 0);
  EXPECT_GT(profile.exposure_offset_sigma, 0);
  EXPECT_GT(profile.noise_sigma, 0);
  EXPECT_GT(profile.shot_noise, 0);
  try {
    realismProfile("handheld");
    FAIL() << "an unknown profile was accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "realism profile 'handheld' is not one of none, default");
  }
}

TEST(RealismOptions, EachEffectAloneTurnsTheModeOn) {
  for (const RealismOptionInfo& info : realismOptionTable()) {
    if (info.name == "motion_blur_samples" || info.name == "exposure_correlation" || info.name == "realism_seed") {
      continue;  // these shape an effect, they are none themselves
    }
    RealismOptions options;
    info.set(options, "0.01");
    EXPECT_TRUE(options.any()) << info.name;
    EXPECT_EQ(options.check(), "") << info.name;
  }
}

TEST(RealismOptions, InvalidValuesAreNamedInTheCheck) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const struct {
    void (*set)(RealismOptions&, double);
    const char* message;
  } cases[] = {
      {[](RealismOptions& o, double) { o.noise_sigma = -1; }, "noise_sigma must be in [0, 255] levels, got -1"},
      {[](RealismOptions& o, double v) { o.pose_noise_m = v; }, "pose_noise_m must be in [0, 1] metres, got nan"},
      {[](RealismOptions& o, double) { o.pose_noise_deg = 90; }, "pose_noise_deg must be in [0, 45] degrees, got 90"},
      {[](RealismOptions& o, double) { o.pose_drift_m = -0.1; }, "pose_drift_m must be in [0, 1] m/sqrt(s)"},
      {[](RealismOptions& o, double v) { o.pose_drift_deg = v; }, "pose_drift_deg must be in [0, 45] deg/sqrt(s)"},
      {[](RealismOptions& o, double) { o.time_offset_s = 2; }, "time_offset_s must be in [-1, 1] seconds, got 2"},
      {[](RealismOptions& o, double) { o.rolling_shutter_s = -0.01; }, "rolling_shutter_s must be in [0, 1] seconds"},
      {[](RealismOptions& o, double v) { o.motion_blur_s = v; }, "motion_blur_s must be in [0, 1] seconds, got nan"},
      {[](RealismOptions& o, double) { o.motion_blur_samples = 0; }, "motion_blur_samples must be in 1..64, got 0"},
      {[](RealismOptions& o, double) { o.exposure_gain_sigma = -0.5; }, "exposure_gain_sigma must be in [0, 2]"},
      {[](RealismOptions& o, double v) { o.exposure_offset_sigma = v; }, "exposure_offset_sigma must be in [0, 255]"},
      {[](RealismOptions& o, double) { o.exposure_correlation = 1; }, "exposure_correlation must be in [0, 1), got 1"},
      {[](RealismOptions& o, double) { o.shot_noise = -2; }, "shot_noise must be in [0, 255] levels^2 per level"},
  };
  for (const auto& c : cases) {
    RealismOptions options = realismProfile("default");
    c.set(options, nan);
    EXPECT_NE(options.check().find(c.message), std::string::npos) << options.check();
  }
  // Two problems: two lines.
  RealismOptions two;
  two.noise_sigma = -1;
  two.time_offset_s = nan;
  EXPECT_EQ(two.check(),
            "time_offset_s must be in [-1, 1] seconds, got nan\nnoise_sigma must be in [0, 255] levels, got -1\n");
  // What uses the options refuses them with the same text.
  try {
    drawFrameDisturbances(two, 3, 0.5);
    FAIL() << "invalid options were used";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "invalid realism options:\n" + two.check());
  }
  EXPECT_THROW(drawFrameDisturbances(RealismOptions(), 3, 0), InputError);  // no time base
}

TEST(RealismOptions, TheTableSetsAndReadsEveryFieldByName) {
  RealismOptions options;
  setOption(options, "noise_sigma", "2.5");
  setOption(options, "motion_blur_samples", "12");
  setOption(options, "realism_seed", "42");
  setOption(options, "time_offset_s", "-0.01");
  EXPECT_EQ(options.noise_sigma, 2.5);
  EXPECT_EQ(options.motion_blur_samples, 12);
  EXPECT_EQ(options.seed, 42u);
  EXPECT_EQ(options.time_offset_s, -0.01);
  for (const RealismOptionInfo& info : realismOptionTable()) {
    EXPECT_FALSE(info.help.empty()) << info.name;
    RealismOptions copy;
    info.set(copy, info.get(options));
    EXPECT_EQ(info.get(copy), info.get(options)) << info.name;
  }
  try {
    setOption(options, "noise_sigma", "2x");
    FAIL() << "'2x' was accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "option noise_sigma: '2x' is not a valid number");
  }
  EXPECT_THROW(setOption(options, "realism_seed", "-1"), InputError);
  EXPECT_THROW(setOption(options, "motion_blur_samples", "2.5"), InputError);
}

}  // namespace
}  // namespace amhmvs
