// Which frames of a camera stream become keyframes (ROS-free; the mapping
// nodelet's inputs and amhmvs_map both pick with it).
//
// A frame is a candidate when the camera moved at least min_translation_m or
// turned at least min_rotation_deg since the last keyframe (both 0: every
// frame is a candidate). A candidate is then refused
//   - as a pure rotation: it only turned, moving less than
//     min_turning_translation_fraction x min_translation_m. A keyframe with
//     (almost) no baseline to the last one gets no source view at a usable
//     triangulation angle, or only wide-angle ones that fail (real video:
//     fast head turns of 6-11 deg with 3-12 cm per frame gave keyframes whose
//     sources sat at 26-28 deg); the camera is taken again once it has moved;
//   - as blurred: its sharpness (imageSharpness) is below
//     min_relative_sharpness x the median of the last sharpness_history
//     candidates' (refused ones included, so that a change of scene content
//     moves the median along). Motion blur smears the fine texture that
//     PatchMatch matches; the next, sharper frame is usually a frame later.
//     After max_blurred_in_a_row refusals the candidate is taken anyway
//     (counted), so that a long blurred stretch still gets mapped.
// Refusals are counted by reason (KeyframePickerStats).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <string>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

struct KeyframePickerOptions {
  double min_translation_m = 0.05;  // a candidate after this much motion ...
  double min_rotation_deg = 5.0;    // ... or this much rotation (both 0: every frame)
  // A candidate that moved less than this fraction of min_translation_m is a
  // pure rotation and refused (0: off). Only applies when min_translation_m > 0.
  double min_turning_translation_fraction = 0.5;
  // A candidate sharper than this fraction of the recent candidates' median is
  // taken; a blurrier one is refused (0: off).
  double min_relative_sharpness = 0.8;
  size_t sharpness_history = 9;     // recent candidates whose sharpness makes the median
  size_t max_blurred_in_a_row = 4;  // then the next candidate is taken whatever its sharpness

  bool everyFrame() const { return min_translation_m <= 0 && min_rotation_deg <= 0; }
  bool rejectsBlur() const { return min_relative_sharpness > 0; }
  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

enum class PickDecision { kKeyframe, kTooClose, kPureRotation, kBlurred };
const char* pickDecisionName(PickDecision decision);

struct KeyframePickerStats {
  uint64_t frames_offered = 0;
  uint64_t keyframes = 0;
  uint64_t too_close = 0;               // moved and turned less than the thresholds
  uint64_t refused_pure_rotation = 0;
  uint64_t refused_blurred = 0;
  uint64_t blurred_taken_anyway = 0;    // after max_blurred_in_a_row refusals
};

// Sharpness of an 8-bit image (grey, or RGB taken as its luma) that hardly
// depends on the scene or the exposure: the mean squared central-difference
// gradient at full resolution divided by the same at half resolution (2x2
// means). Fine texture carries most of the first; blur removes it first, and
// gain cancels. About 0.35-0.6 on the redkitchen video (motion-blurred frames
// at the low end); 0 for an image without any gradient at half resolution.
double imageSharpness(const ImageViewU8& image);

class KeyframePicker {
 public:
  // Throws InputError when the options are invalid.
  explicit KeyframePicker(const KeyframePickerOptions& options);

  // Decides about the next frame of the stream. `sharpness` is called only
  // for candidates (frames that pass the motion test) and only when blur is
  // refused, so that a caller decodes only those images; it may be empty
  // otherwise; a non-finite sharpness is not judged (nor remembered). The
  // first frame (after construction or reset) is a keyframe (no history).
  PickDecision offer(const Eigen::Isometry3d& camera_to_world, const std::function<double()>& sharpness);

  // New options from the next frame on; the last keyframe and the history
  // stay. Throws InputError when they are invalid (the old ones stay).
  void setOptions(const KeyframePickerOptions& options);
  void reset();  // forgets the last keyframe and the sharpness history (not the stats)
  const KeyframePickerStats& stats() const { return stats_; }
  const KeyframePickerOptions& options() const { return options_; }

 private:
  PickDecision motionDecision(const Eigen::Isometry3d& camera_to_world) const;
  bool blurred(double sharpness);

  KeyframePickerOptions options_;
  KeyframePickerStats stats_;
  bool have_keyframe_ = false;
  Eigen::Isometry3d last_keyframe_ = Eigen::Isometry3d::Identity();
  std::deque<double> recent_sharpness_;
  size_t blurred_in_a_row_ = 0;
};

}  // namespace amhmvs
