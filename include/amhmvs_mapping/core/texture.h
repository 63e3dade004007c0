// Weakly textured pixels, where photometric matching has little to hold on
// to: the planar prior holds them (mvs/planar_prior.h) and the reports judge
// them apart (eval/depth_metrics.h).
#pragma once

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// 255 where the mean grey-level gradient (|dI/dx| + |dI/dy|, central
// differences) over the (2 radius + 1)^2 window around the pixel is below
// `max_gradient` grey levels per pixel, else 0. Throws InputError for an
// image that is not grey.
constexpr float kWeakTextureGradient = 3.0f;
constexpr int kWeakTextureRadius = 2;
ImageU8 weakTextureMask(const ImageViewU8& grey, float max_gradient = kWeakTextureGradient,
                        int radius = kWeakTextureRadius);

}  // namespace amhmvs
