// Portable Float Map (PFM) files: float32 depth, disparity and normal maps.
#pragma once

#include <string>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Reads a 1-channel ("Pf") or 3-channel ("PF") PFM. Rows come back top-down
// (the file stores them bottom-up); either byte order (scale sign) is read.
// NaN and inf are kept bit for bit. Throws InputError naming the file and the
// problem for malformed or truncated files.
ImageF readPfm(const std::string& path);

// Writes a 1- or 3-channel image as little-endian PFM (scale -1), rows
// bottom-up, values bit for bit. Throws InputError for other channel counts or
// when the file cannot be written.
void writePfm(const std::string& path, const ImageF& image);

}  // namespace amhmvs
