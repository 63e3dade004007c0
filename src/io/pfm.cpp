#include "amhmvs_mapping/io/pfm.h"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "file_util.h"

namespace amhmvs {

namespace {

// Next whitespace-separated header token starting at *pos; leaves *pos on the
// single whitespace character that ends it.
std::string nextToken(const std::string& bytes, size_t* pos, const std::string& path,
                      const char* what) {
  while (*pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[*pos]))) ++*pos;
  const size_t start = *pos;
  while (*pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[*pos])) &&
         *pos - start < 64) {
    ++*pos;
  }
  if (*pos == start || *pos >= bytes.size()) {
    throw InputError(path + ": truncated PFM header (missing " + what + ")");
  }
  return bytes.substr(start, *pos - start);
}

int parseDimension(const std::string& token, const std::string& path, const char* what) {
  char* end = nullptr;
  const long v = std::strtol(token.c_str(), &end, 10);
  // 1<<20 pixels per side is far beyond any camera and keeps w*h*c in range.
  if (*end != '\0' || v <= 0 || v > (1L << 20)) {
    throw InputError(path + ": invalid PFM " + what + " '" + token + "'");
  }
  return static_cast<int>(v);
}

uint32_t byteSwap(uint32_t v) {
  return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

}  // namespace

ImageF readPfm(const std::string& path) {
  const std::string bytes = internal::readFileBytes(path);
  size_t pos = 0;
  const std::string magic = nextToken(bytes, &pos, path, "magic");
  int channels = 0;
  if (magic == "Pf") {
    channels = 1;
  } else if (magic == "PF") {
    channels = 3;
  } else {
    throw InputError(path + ": not a PFM file (magic '" + magic.substr(0, 8) +
                     "', expected 'Pf' or 'PF')");
  }
  const int width = parseDimension(nextToken(bytes, &pos, path, "width"), path, "width");
  const int height = parseDimension(nextToken(bytes, &pos, path, "height"), path, "height");
  const std::string scale_token = nextToken(bytes, &pos, path, "scale");
  char* end = nullptr;
  const double scale = std::strtod(scale_token.c_str(), &end);
  if (*end != '\0' || !std::isfinite(scale) || scale == 0.0) {
    throw InputError(path + ": invalid PFM scale '" + scale_token +
                     "' (must be a non-zero number; its sign gives the byte order)");
  }
  if (!std::isspace(static_cast<unsigned char>(bytes[pos]))) {
    throw InputError(path + ": invalid PFM scale '" + scale_token + "...' (too long)");
  }
  ++pos;  // Exactly one whitespace character separates header and data.

  const size_t count = static_cast<size_t>(width) * height * channels;
  const size_t needed = count * sizeof(float);
  if (bytes.size() - pos < needed) {
    throw InputError(path + ": truncated PFM data (" + std::to_string(width) + "x" +
                     std::to_string(height) + "x" + std::to_string(channels) + " needs " +
                     std::to_string(needed) + " bytes, file has " +
                     std::to_string(bytes.size() - pos) + ")");
  }

  const bool swap = (scale < 0) != internal::isLittleEndianHost();
  ImageF image(width, height, channels);
  const size_t row_values = static_cast<size_t>(width) * channels;
  for (int file_row = 0; file_row < height; ++file_row) {
    // File rows run bottom-up.
    float* dst = &image.data[static_cast<size_t>(height - 1 - file_row) * row_values];
    const char* src = bytes.data() + pos + file_row * row_values * sizeof(float);
    for (size_t i = 0; i < row_values; ++i) {
      uint32_t bits;
      std::memcpy(&bits, src + i * sizeof(float), sizeof(bits));
      if (swap) bits = byteSwap(bits);
      std::memcpy(&dst[i], &bits, sizeof(bits));
    }
  }
  return image;
}

void writePfm(const std::string& path, const ImageF& image) {
  if (image.channels != 1 && image.channels != 3) {
    throw InputError(path + ": PFM holds 1 or 3 channels, image has " +
                     std::to_string(image.channels));
  }
  if (image.width <= 0 || image.height <= 0 ||
      image.data.size() != image.pixelCount() * image.channels) {
    throw InputError(path + ": cannot write an empty or inconsistent image as PFM");
  }
  const bool little = internal::isLittleEndianHost();
  std::string bytes = std::string(image.channels == 3 ? "PF" : "Pf") + "\n" +
                      std::to_string(image.width) + " " + std::to_string(image.height) +
                      "\n-1\n";
  const size_t header = bytes.size();
  const size_t row_values = static_cast<size_t>(image.width) * image.channels;
  bytes.resize(header + row_values * image.height * sizeof(float));
  for (int file_row = 0; file_row < image.height; ++file_row) {
    const float* src = &image.data[static_cast<size_t>(image.height - 1 - file_row) * row_values];
    char* dst = &bytes[header + file_row * row_values * sizeof(float)];
    for (size_t i = 0; i < row_values; ++i) {
      uint32_t bits;
      std::memcpy(&bits, &src[i], sizeof(bits));
      if (!little) bits = byteSwap(bits);
      std::memcpy(dst + i * sizeof(float), &bits, sizeof(bits));
    }
  }
  writeFileAtomically(path, bytes, "PFM image");
}

}  // namespace amhmvs
