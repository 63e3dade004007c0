// Which frames of a recorded sequence become keyframes: a window of the
// sequence (start, stride, count), then motion since the last keyframe; and
// the keyframe made of a frame.
#pragma once

#include <vector>

#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "map_options.h"

namespace amhmvs {

// Indices into `frames` of the keyframes, in order. The first frame of the
// window always is one; a later frame when its camera centre moved at least
// min_translation_m or its orientation turned at least min_rotation_deg
// since the last keyframe (both 0: every frame of the window).
std::vector<size_t> pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection);

// The keyframe of a frame: its image decoded and scaled to max_image_size,
// with the camera scaled alike, and the depth range given by the options or
// the layout. Throws InputError for an image that does not match its camera.
Keyframe makeKeyframe(const PosedFrame& frame, const MapToolOptions& options);

}  // namespace amhmvs
