// Reading and writing 8-bit images. Binary PGM/PPM are handled natively; PNG,
// JPEG and other formats are decoded through OpenCV only in builds that define
// AMHMVS_WITH_OPENCV. PNG is always writable by a small built-in encoder, so
// the core needs neither libpng nor OpenCV to produce viewable output.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Lower-case file extensions (no dot) that readImage may accept:
// png jpg jpeg pgm ppm pnm bmp tif tiff.
const std::vector<std::string>& supportedImageExtensions();

// True when the path ends in one of supportedImageExtensions(), ignoring case.
bool hasImageExtension(const std::string& path);

// True when this build decodes PNG/JPEG/BMP/TIFF (compiled with OpenCV).
bool canDecodeCompressedImages();

// Reads an 8-bit image: 1 channel (gray) or 3 channels (RGB, interleaved; never
// BGR). Binary PGM (P5) and PPM (P6) are read natively, including header
// comments; other maxvals are rescaled to 0..255. Other formats need OpenCV
// (EXIF orientation is ignored, so the size matches the file header). Throws
// InputError naming the file and the problem.
ImageU8 readImage(const std::string& path);

// Reads a single-channel 16-bit image (depth maps: Kinect, TUM, 7-Scenes)
// with its stored values: binary PGM with maxval > 255 natively, PNG and
// other formats through OpenCV. Throws InputError naming the file for other
// channel counts or sample types, and for PNG in builds without OpenCV.
Image<uint16_t> readImage16(const std::string& path);

// Image width and height from the file header alone, without decoding pixels:
// PNG (IHDR), JPEG (SOFn marker), BMP and PGM/PPM. Returns false for formats
// it cannot size from the header (the caller may then decode the image).
// Throws InputError when the file cannot be read or a recognised header is
// malformed, including a side of 0 or above kMaxImageSide.
bool readImageSize(const std::string& path, int* width, int* height);

// The longest image side the readers accept (2^20 px: far beyond any camera,
// and width * height * channels stays well inside size_t and int indexing).
constexpr int kMaxImageSide = 1 << 20;

// Writes a binary PGM (1 channel) or PPM (3 channels).
void writePnm(const std::string& path, const ImageU8& image);

// Writes an 8-bit gray (1 channel) or RGB (3 channels) PNG with a built-in,
// uncompressed (stored deflate) encoder.
void writePng(const std::string& path, const ImageU8& image);

}  // namespace amhmvs
