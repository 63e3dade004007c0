// Internal: image decoding through OpenCV, compiled only with
// AMHMVS_WITH_OPENCV (src/io/image_io_opencv.cpp). Kept apart so the rest of
// the core never includes OpenCV headers.
#pragma once

#include <string>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {
namespace internal {

// Decodes any format OpenCV reads to 8-bit gray (1 channel) or RGB (3
// channels; alpha is dropped, BGR is converted). Throws InputError naming the
// file when OpenCV cannot decode it.
ImageU8 readImageOpenCv(const std::string& path);

// Decodes a single-channel 16-bit image bit for bit (IMREAD_ANYDEPTH).
Image<uint16_t> readImage16OpenCv(const std::string& path);

}  // namespace internal
}  // namespace amhmvs
