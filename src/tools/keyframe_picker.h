// Which frames of a recorded sequence become keyframes: a window of the
// sequence (start, stride, count), then the core KeyframePicker (motion,
// pure rotation, blur); and the keyframe made of a frame.
#pragma once

#include <map>
#include <vector>

#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "map_options.h"

namespace amhmvs {

struct PickedKeyframes {
  std::vector<size_t> indices;  // into the sequence's frames, in order
  KeyframePickerStats stats;
  // Frame index -> its image as the blur check decoded it, for makeKeyframe
  // (not decoded twice), up to kDecodedBudgetBytes.
  std::map<size_t, ImageU8> decoded;
  static constexpr size_t kDecodedBudgetBytes = size_t{256} << 20;
  // The decoded image of frame `index`, moved out (empty when not kept).
  ImageU8 takeDecoded(size_t index);
};

// The keyframes of the window. An image is decoded only for the frames that
// pass the motion test, and only when blur is refused (its sharpness).
PickedKeyframes pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection);

// The keyframe of a frame: its image (`decoded` when given, else read from
// its file) scaled to max_image_size, with the camera scaled alike, and the
// depth range given by the options or the layout. Throws InputError for an
// image that does not match its camera.
Keyframe makeKeyframe(const PosedFrame& frame, const MapToolOptions& options, ImageU8 decoded = ImageU8());

}  // namespace amhmvs
