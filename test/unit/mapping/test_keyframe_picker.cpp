// KeyframePicker (mapping/keyframe_picker.h): motion, pure-rotation and blur
// tests, and the sharpness measure they use.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "mapping_test_helpers.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

KeyframePickerOptions motionOnly() {
  KeyframePickerOptions options;
  options.min_translation_m = 0.05;
  options.min_rotation_deg = 5;
  options.min_relative_sharpness = 0;
  return options;
}

// Box blur of radius r along x (motion blur of a horizontal pan).
ImageU8 horizontalBlur(const ImageU8& image, int r) {
  ImageU8 out(image.width, image.height, image.channels);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < image.channels; ++c) {
        int sum = 0, n = 0;
        for (int dx = -r; dx <= r; ++dx) {
          const int xx = std::min(std::max(x + dx, 0), image.width - 1);
          sum += image.at(xx, y, c);
          ++n;
        }
        out.at(x, y, c) = static_cast<uint8_t>((sum + n / 2) / n);
      }
  return out;
}

// A textured scene as a camera sees it (the synthetic room's first view), grey.
ImageU8 roomView() {
  const SyntheticWorld world = makeIndoorRoomWorld(1);
  return toGray(renderView(world, makeSmoothTrajectory(2, 160, 120, 1).front(), 1).image);
}

TEST(KeyframePicker, MotionDecidesAndTheFirstFrameIsAKeyframe) {
  KeyframePicker picker(motionOnly());
  EXPECT_EQ(picker.offer(test::poseAt({0, 0, 0}, 0), {}), PickDecision::kKeyframe);
  EXPECT_EQ(picker.offer(test::poseAt({0.04, 0, 0}, 4), {}), PickDecision::kTooClose);
  EXPECT_EQ(picker.offer(test::poseAt({0.05, 0, 0}, 0), {}), PickDecision::kKeyframe);  // >= min_translation
  EXPECT_EQ(picker.offer(test::poseAt({0.05, 0, 0}, 6), {}), PickDecision::kPureRotation);  // turned, did not move
  // Turned and moved more than half of min_translation: a keyframe.
  EXPECT_EQ(picker.offer(test::poseAt({0.08, 0, 0}, 6), {}), PickDecision::kKeyframe);
  EXPECT_EQ(picker.stats().frames_offered, 5u);
  EXPECT_EQ(picker.stats().keyframes, 3u);
  EXPECT_EQ(picker.stats().too_close, 1u);
  EXPECT_EQ(picker.stats().refused_pure_rotation, 1u);
  picker.reset();
  EXPECT_EQ(picker.offer(test::poseAt({0.08, 0, 0}, 6), {}), PickDecision::kKeyframe);  // first after reset
}

TEST(KeyframePicker, PureRotationTestCanBeSwitchedOff) {
  KeyframePickerOptions options = motionOnly();
  options.min_turning_translation_fraction = 0;
  KeyframePicker picker(options);
  picker.offer(test::poseAt({0, 0, 0}, 0), {});
  EXPECT_EQ(picker.offer(test::poseAt({0, 0, 0}, 6), {}), PickDecision::kKeyframe);
  // Rotation alone as the criterion (no translation threshold): no pure-rotation test.
  options = motionOnly();
  options.min_translation_m = 0;
  KeyframePicker by_rotation(options);
  by_rotation.offer(test::poseAt({0, 0, 0}, 0), {});
  EXPECT_EQ(by_rotation.offer(test::poseAt({0, 0, 0}, 6), {}), PickDecision::kKeyframe);
}

TEST(KeyframePicker, SharpnessIgnoresGainAndFallsWithBlur) {
  const ImageU8 sharp = roomView();
  const double s = imageSharpness(sharp);
  EXPECT_GT(s, 0.2);
  ImageU8 dimmer = sharp;
  for (uint8_t& v : dimmer.data) v = static_cast<uint8_t>(std::lround(0.5 * v + 20));
  EXPECT_NEAR(imageSharpness(dimmer), s, 0.03 * s);  // gain and offset cancel up to 8-bit rounding
  // 2 px of motion blur (the realism profile's default) takes most fine-scale energy.
  const ImageU8 blurred = horizontalBlur(sharp, 2);
  EXPECT_LT(imageSharpness(blurred), 0.75 * s);
  const ImageU8 flat(64, 48, 1, 128), tiny(4, 4, 1, 0);
  EXPECT_EQ(imageSharpness(flat), 0.0);  // no gradient at all
  EXPECT_EQ(imageSharpness(tiny), 0.0);  // too small for a half-resolution gradient
  // RGB is judged by its luma: equal channels give the grey image's value.
  ImageU8 rgb(sharp.width, sharp.height, 3);
  for (size_t i = 0; i < sharp.data.size(); ++i) rgb.data[3 * i] = rgb.data[3 * i + 1] = rgb.data[3 * i + 2] = sharp.data[i];
  EXPECT_NEAR(imageSharpness(rgb), s, 1e-9);
}

TEST(KeyframePicker, RefusesABlurredCandidateAndTakesTheNextSharpOne) {
  KeyframePickerOptions options = motionOnly();
  options.min_relative_sharpness = 0.8;
  KeyframePicker picker(options);
  const ImageU8 sharp = roomView();
  const ImageU8 blurred = horizontalBlur(sharp, 3);
  int sharpness_calls = 0;
  auto of = [&sharpness_calls](const ImageU8& image) {
    return [&sharpness_calls, &image] {
      ++sharpness_calls;
      return imageSharpness(image);
    };
  };
  for (int i = 0; i < 4; ++i) EXPECT_EQ(picker.offer(test::poseAt({0.1 * i, 0, 0}, 0), of(sharp)), PickDecision::kKeyframe);
  EXPECT_EQ(picker.offer(test::poseAt({0.31, 0, 0}, 0), of(sharp)), PickDecision::kTooClose);
  EXPECT_EQ(sharpness_calls, 4);  // only candidates are judged
  EXPECT_EQ(picker.offer(test::poseAt({0.4, 0, 0}, 0), of(blurred)), PickDecision::kBlurred);
  EXPECT_EQ(picker.offer(test::poseAt({0.41, 0, 0}, 0), of(sharp)), PickDecision::kKeyframe);  // still far from 0.3
  // A frame that cannot be judged (non-finite sharpness) is not refused.
  EXPECT_EQ(picker.offer(test::poseAt({0.6, 0, 0}, 0), [] { return std::nan(""); }), PickDecision::kKeyframe);
  EXPECT_EQ(picker.stats().refused_blurred, 1u);
  EXPECT_EQ(picker.stats().keyframes, 6u);
}

TEST(KeyframePicker, TakesABlurredFrameAfterTooManyRefusals) {
  KeyframePickerOptions options = motionOnly();
  options.min_relative_sharpness = 0.8;
  options.max_blurred_in_a_row = 2;
  options.sharpness_history = 5;
  KeyframePicker picker(options);
  // Candidates by sharpness alone: three of 1.0, then 0.5 again and again.
  double x = 0;
  auto offer = [&](double sharpness) {
    x += 0.1;
    return picker.offer(test::poseAt({x, 0, 0}, 0), [sharpness] { return sharpness; });
  };
  for (int i = 0; i < 3; ++i) EXPECT_EQ(offer(1.0), PickDecision::kKeyframe);
  EXPECT_EQ(offer(0.5), PickDecision::kBlurred);   // median of 1, 1, 1
  EXPECT_EQ(offer(0.5), PickDecision::kBlurred);   // median of 1, 1, 1, 0.5
  EXPECT_EQ(offer(0.5), PickDecision::kKeyframe);  // median still 1, but the third in a row is taken
  EXPECT_EQ(picker.stats().refused_blurred, 2u);
  EXPECT_EQ(picker.stats().blurred_taken_anyway, 1u);
  // The last 5 are 1, 1, 0.5, 0.5, 0.5: the history followed the scene, 0.5 is the norm now.
  EXPECT_EQ(offer(0.5), PickDecision::kKeyframe);
  EXPECT_EQ(picker.stats().blurred_taken_anyway, 1u);
}

TEST(KeyframePicker, RefusesInvalidOptions) {
  KeyframePickerOptions options;
  options.min_translation_m = -1;
  EXPECT_INPUT_ERROR(KeyframePicker{options}, "keyframe picking", "min_translation_m");
  options = KeyframePickerOptions();
  options.min_relative_sharpness = 1.5;
  EXPECT_INPUT_ERROR(KeyframePicker{options}, "min_relative_sharpness", "[0, 1]");
  options = KeyframePickerOptions();
  options.min_rotation_deg = std::nan("");
  EXPECT_INPUT_ERROR(KeyframePicker{options}, "min_rotation_deg", "nan");
  KeyframePicker picker{KeyframePickerOptions()};
  options = KeyframePickerOptions();
  options.sharpness_history = 1;
  EXPECT_INPUT_ERROR(picker.setOptions(options), "sharpness_history", "at least 3");
  EXPECT_EQ(picker.options().sharpness_history, KeyframePickerOptions().sharpness_history);  // unchanged
}

}  // namespace
}  // namespace amhmvs
