// False-colour rendering of depth maps for viewing and debugging.
#pragma once

#include <utility>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Maps a 1-channel depth (or any scalar) image to RGB with the perceptually
// ordered "viridis" map: values <= min are dark purple, values >= max are
// yellow, linear in between. NaN and +-inf pixels are black. With min == max
// every finite pixel gets the map's middle colour. Throws InputError for a
// non-finite or inverted range, or a multi-channel image.
ImageU8 colorizeDepth(const ImageF& depth, float min, float max);

// Robust display range: the low_pct and high_pct quantiles (fractions in
// [0, 1], linearly interpolated) of the finite pixels. Throws InputError when
// the image has no finite pixel or the fractions are out of order.
std::pair<float, float> robustRange(const ImageF& image, double low_pct = 0.02,
                                    double high_pct = 0.98);

}  // namespace amhmvs
