#include "keyframe_picker.h"

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/mvs/problem_builder.h"

#include <limits>

namespace amhmvs {

PickedKeyframes pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection) {
  KeyframePicker picker(selection.picking);
  PickedKeyframes picked;
  size_t looked_at = 0, decoded_bytes = 0;
  for (size_t i = selection.start; i < frames.size(); i += selection.stride) {
    if (selection.count > 0 && looked_at++ == selection.count) break;
    const PosedFrame& frame = frames[i];
    ImageU8 image;
    // An unreadable image is not judged here: the run reaches it in order
    // and stops there with its name, after the earlier results are written.
    const auto sharpness = [&frame, &image] {
      try {
        image = readImage(frame.image_path);
        return imageSharpness(image);
      } catch (const InputError&) {
        return std::numeric_limits<double>::quiet_NaN();
      }
    };
    if (picker.offer(cameraToWorld(frame.camera), sharpness) != PickDecision::kKeyframe) continue;
    picked.indices.push_back(i);
    if (!image.empty() && decoded_bytes + image.data.size() <= PickedKeyframes::kDecodedBudgetBytes) {
      decoded_bytes += image.data.size();
      picked.decoded[i] = std::move(image);
    }
  }
  picked.stats = picker.stats();
  return picked;
}

ImageU8 PickedKeyframes::takeDecoded(size_t index) {
  const auto found = decoded.find(index);
  if (found == decoded.end()) return ImageU8();
  ImageU8 image = std::move(found->second);
  decoded.erase(found);
  return image;
}

Keyframe makeKeyframe(const PosedFrame& frame, const MapToolOptions& options, ImageU8 decoded) {
  Keyframe keyframe;
  keyframe.id = frame.id;
  keyframe.stamp = frame.stamp;
  keyframe.image = decoded.empty() ? readImage(frame.image_path) : std::move(decoded);
  keyframe.camera = frame.camera;
  if (!keyframe.image.sameSize(frame.camera.width, frame.camera.height)) {
    throw InputError(frame.image_path + ": image is " + std::to_string(keyframe.image.width) + "x" +
                     std::to_string(keyframe.image.height) + ", its camera " + std::to_string(frame.camera.width) +
                     "x" + std::to_string(frame.camera.height));
  }
  ProblemOptions size;
  size.max_image_size = options.max_image_size;
  int width = 0, height = 0;
  scaledSize(keyframe.image.width, keyframe.image.height, size, &width, &height);
  if (width != keyframe.image.width || height != keyframe.image.height) {
    keyframe.image = resizeArea(keyframe.image, width, height);
    keyframe.camera = keyframe.camera.resized(width, height);
  }
  const bool given = options.depth_min > 0;  // the options' range wins over the layout's
  keyframe.depth_min = given ? options.depth_min : frame.depth_min;
  keyframe.depth_max = given ? options.depth_max : frame.depth_max;
  return keyframe;
}

}  // namespace amhmvs
