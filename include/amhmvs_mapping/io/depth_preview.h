// The one picture of a depth map that every tool writes (amhmvs_depth's
// depth.png, amhmvs_map's previews; scripts/demo_outputs.py draws the same):
// viridis over a robust range (colormap.h), NaN black, and below it a scale
// bar from near to far labelled with both ends in metres.
#pragma once

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Rows added below the depth image for the scale bar and its labels.
constexpr int kScaleBarRows = 22;

// RGB preview of a 1-channel depth map (metres): the colour range is the
// map's 2..98 % depths, or [fallback_min, fallback_max] when it has no finite
// depth. Throws InputError for a multi-channel image or an invalid fallback.
ImageU8 depthPreview(const ImageF& depth, float fallback_min, float fallback_max);

}  // namespace amhmvs
