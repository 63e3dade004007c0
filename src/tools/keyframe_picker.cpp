#include "keyframe_picker.h"

#include <cmath>

namespace amhmvs {

namespace {

double rotationDeg(const PinholeCamera& a, const PinholeCamera& b) {
  return Eigen::AngleAxisd(a.R * b.R.transpose()).angle() * 180.0 / M_PI;
}

}  // namespace

std::vector<size_t> pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection) {
  std::vector<size_t> picked;
  const bool every_frame = selection.min_translation_m <= 0 && selection.min_rotation_deg <= 0;
  size_t looked_at = 0;
  for (size_t i = selection.start; i < frames.size(); i += selection.stride) {
    if (selection.count > 0 && looked_at++ == selection.count) break;
    if (!picked.empty() && !every_frame) {
      const PinholeCamera& last = frames[picked.back()].camera;
      const PinholeCamera& now = frames[i].camera;
      const bool moved = selection.min_translation_m > 0 &&
                         (now.center() - last.center()).norm() >= selection.min_translation_m;
      const bool turned = selection.min_rotation_deg > 0 && rotationDeg(now, last) >= selection.min_rotation_deg;
      if (!moved && !turned) continue;
    }
    picked.push_back(i);
  }
  return picked;
}

}  // namespace amhmvs
