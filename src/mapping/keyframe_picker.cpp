#include "amhmvs_mapping/mapping/keyframe_picker.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"

namespace amhmvs {

namespace {

// Fewer recent candidates than this: no median to judge blur by yet.
constexpr size_t kMinSharpnessSamples = 3;

// Luma (BT.601) of pixel (x, y) of a grey or RGB view.
double luma(const ImageViewU8& image, int x, int y) {
  if (image.channels < 3) return image.at(x, y);
  return 0.299 * image.at(x, y, 0) + 0.587 * image.at(x, y, 1) + 0.114 * image.at(x, y, 2);
}

// Mean squared central-difference gradient of a row-major float image.
double meanSquaredGradient(const std::vector<double>& pixels, int width, int height) {
  double sum = 0;
  long count = 0;
  for (int y = 1; y + 1 < height; ++y) {
    for (int x = 1; x + 1 < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      const double gx = pixels[i + 1] - pixels[i - 1];
      const double gy = pixels[i + width] - pixels[i - width];
      sum += gx * gx + gy * gy;
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

}  // namespace

std::string KeyframePickerOptions::validate() const {
  std::ostringstream why;
  if (!(std::isfinite(min_translation_m) && min_translation_m >= 0))
    why << "min_translation_m must be finite and >= 0 (got " << min_translation_m << ")\n";
  if (!(std::isfinite(min_rotation_deg) && min_rotation_deg >= 0 && min_rotation_deg <= 180))
    why << "min_rotation_deg must be in [0, 180] (got " << min_rotation_deg << ")\n";
  if (!(min_turning_translation_fraction >= 0 && min_turning_translation_fraction <= 1))
    why << "min_turning_translation_fraction must be in [0, 1] (got " << min_turning_translation_fraction << ")\n";
  if (!(min_relative_sharpness >= 0 && min_relative_sharpness <= 1))
    why << "min_relative_sharpness must be in [0, 1] (got " << min_relative_sharpness << ")\n";
  if (rejectsBlur() && sharpness_history < kMinSharpnessSamples)
    why << "sharpness_history must be at least " << kMinSharpnessSamples << " (got " << sharpness_history << ")\n";
  return why.str();
}

const char* pickDecisionName(PickDecision decision) {
  switch (decision) {
    case PickDecision::kKeyframe: return "keyframe";
    case PickDecision::kTooClose: return "too close";
    case PickDecision::kPureRotation: return "pure rotation";
    case PickDecision::kBlurred: return "blurred";
  }
  return "?";
}

double imageSharpness(const ImageViewU8& image) {
  const int width = image.width, height = image.height;
  const int half_width = width / 2, half_height = height / 2;
  if (image.empty() || half_width < 3 || half_height < 3) return 0.0;
  std::vector<double> full(static_cast<size_t>(width) * height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) full[static_cast<size_t>(y) * width + x] = luma(image, x, y);
  std::vector<double> half(static_cast<size_t>(half_width) * half_height);
  for (int y = 0; y < half_height; ++y) {
    for (int x = 0; x < half_width; ++x) {
      const size_t i = static_cast<size_t>(2 * y) * width + 2 * x;
      half[static_cast<size_t>(y) * half_width + x] = 0.25 * (full[i] + full[i + 1] + full[i + width] + full[i + width + 1]);
    }
  }
  const double coarse = meanSquaredGradient(half, half_width, half_height);
  return coarse > 0 ? meanSquaredGradient(full, width, height) / coarse : 0.0;
}

KeyframePicker::KeyframePicker(const KeyframePickerOptions& options) { setOptions(options); }

void KeyframePicker::setOptions(const KeyframePickerOptions& options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("keyframe picking: " + problems);
  options_ = options;
  while (recent_sharpness_.size() > options_.sharpness_history) recent_sharpness_.pop_front();
}

void KeyframePicker::reset() {
  have_keyframe_ = false;
  recent_sharpness_.clear();
  blurred_in_a_row_ = 0;
}

PickDecision KeyframePicker::motionDecision(const Eigen::Isometry3d& camera_to_world) const {
  if (!have_keyframe_ || options_.everyFrame()) return PickDecision::kKeyframe;
  const double moved = (camera_to_world.translation() - last_keyframe_.translation()).norm();
  const double turned = rotationAngleDeg(last_keyframe_.linear().transpose() * camera_to_world.linear());
  const bool far_enough = options_.min_translation_m > 0 && moved >= options_.min_translation_m;
  const bool turned_enough = options_.min_rotation_deg > 0 && turned >= options_.min_rotation_deg;
  if (!far_enough && !turned_enough) return PickDecision::kTooClose;
  if (!far_enough && options_.min_translation_m > 0 &&
      moved < options_.min_turning_translation_fraction * options_.min_translation_m)
    return PickDecision::kPureRotation;
  return PickDecision::kKeyframe;
}

bool KeyframePicker::blurred(double sharpness) {
  if (!std::isfinite(sharpness)) return false;
  bool refuse = false;
  if (recent_sharpness_.size() >= kMinSharpnessSamples) {
    const double median = medianOf(std::vector<double>(recent_sharpness_.begin(), recent_sharpness_.end()));
    refuse = sharpness < options_.min_relative_sharpness * median;
  }
  recent_sharpness_.push_back(sharpness);
  if (recent_sharpness_.size() > options_.sharpness_history) recent_sharpness_.pop_front();
  if (!refuse) {
    blurred_in_a_row_ = 0;
    return false;
  }
  if (blurred_in_a_row_ >= options_.max_blurred_in_a_row) {
    ++stats_.blurred_taken_anyway;
    blurred_in_a_row_ = 0;
    return false;
  }
  ++blurred_in_a_row_;
  return true;
}

PickDecision KeyframePicker::offer(const Eigen::Isometry3d& camera_to_world,
                                   const std::function<double()>& sharpness) {
  ++stats_.frames_offered;
  PickDecision decision = motionDecision(camera_to_world);
  if (decision == PickDecision::kKeyframe && options_.rejectsBlur() && sharpness && blurred(sharpness()))
    decision = PickDecision::kBlurred;
  switch (decision) {
    case PickDecision::kKeyframe:
      ++stats_.keyframes;
      have_keyframe_ = true;
      last_keyframe_ = camera_to_world;
      break;
    case PickDecision::kTooClose: ++stats_.too_close; break;
    case PickDecision::kPureRotation: ++stats_.refused_pure_rotation; break;
    case PickDecision::kBlurred: ++stats_.refused_blurred; break;
  }
  return decision;
}

}  // namespace amhmvs
