// Which frames of a recorded sequence become keyframes: a window of the
// sequence (start, stride, count), then motion since the last keyframe.
#pragma once

#include <vector>

#include "amhmvs_mapping/io/posed_sequence.h"
#include "map_options.h"

namespace amhmvs {

// Indices into `frames` of the keyframes, in order. The first frame of the
// window always is one; a later frame when its camera centre moved at least
// min_translation_m or its orientation turned at least min_rotation_deg
// since the last keyframe (both 0: every frame of the window).
std::vector<size_t> pickKeyframes(const std::vector<PosedFrame>& frames, const FrameSelection& selection);

}  // namespace amhmvs
