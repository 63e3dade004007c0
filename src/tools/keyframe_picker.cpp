#include "keyframe_picker.h"

#include "amhmvs_mapping/io/image_io.h"

namespace amhmvs {

PickedKeyframes pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection) {
  KeyframePicker picker(selection.picking);
  PickedKeyframes picked;
  size_t looked_at = 0;
  for (size_t i = selection.start; i < frames.size(); i += selection.stride) {
    if (selection.count > 0 && looked_at++ == selection.count) break;
    const PosedFrame& frame = frames[i];
    const auto sharpness = [&frame] {
      const ImageU8 image = readImage(frame.image_path);
      return imageSharpness(image);
    };
    if (picker.offer(cameraToWorld(frame.camera), sharpness) == PickDecision::kKeyframe) picked.indices.push_back(i);
  }
  picked.stats = picker.stats();
  return picked;
}

}  // namespace amhmvs
