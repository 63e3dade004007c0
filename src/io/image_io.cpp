#include "amhmvs_mapping/io/image_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "file_util.h"

#ifdef AMHMVS_WITH_OPENCV
#include "image_io_opencv.h"
#endif

namespace amhmvs {

namespace {

std::string lowerExtension(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// ---- PNM -------------------------------------------------------------------

struct PnmHeader {
  int channels = 0;  // 1 for P5, 3 for P6
  int width = 0;
  int height = 0;
  int maxval = 0;
  size_t data_offset = 0;
};

bool isPnmMagic(const std::string& head) {
  return head.size() >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '7';
}

// Parses "P5|P6 <w> <h> <maxval>" with '#' comments anywhere between tokens.
PnmHeader parsePnmHeader(const std::string& bytes, const std::string& path) {
  if (!isPnmMagic(bytes)) throw InputError(path + ": not a PNM file");
  PnmHeader h;
  if (bytes[1] == '5') {
    h.channels = 1;
  } else if (bytes[1] == '6') {
    h.channels = 3;
  } else {
    throw InputError(path + ": unsupported PNM type 'P" + std::string(1, bytes[1]) +
                     "' (only binary P5 gray and P6 RGB are read)");
  }
  size_t pos = 2;
  auto next_number = [&](const char* what, long max_value) {
    while (pos < bytes.size()) {
      if (std::isspace(static_cast<unsigned char>(bytes[pos]))) {
        ++pos;
      } else if (bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
      } else {
        break;
      }
    }
    long value = 0;
    size_t digits = 0;
    while (pos < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[pos]))) {
      value = value * 10 + (bytes[pos] - '0');
      ++pos;
      if (++digits > 9) break;
    }
    if (digits == 0 || value <= 0 || value > max_value) {
      throw InputError(path + ": invalid or truncated PNM header (bad " + std::string(what) +
                       ")");
    }
    return static_cast<int>(value);
  };
  h.width = next_number("width", kMaxImageSide);
  h.height = next_number("height", kMaxImageSide);
  h.maxval = next_number("maxval", 65535);
  if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos]))) {
    throw InputError(path + ": invalid or truncated PNM header (no whitespace after maxval)");
  }
  h.data_offset = pos + 1;
  return h;
}

ImageU8 readPnm(const std::string& path) {
  const std::string bytes = internal::readFileBytes(path);
  const PnmHeader h = parsePnmHeader(bytes, path);
  const int bytes_per_sample = h.maxval > 255 ? 2 : 1;
  const size_t count = static_cast<size_t>(h.width) * h.height * h.channels;
  if (bytes.size() - h.data_offset < count * bytes_per_sample) {
    throw InputError(path + ": truncated PNM data (" + std::to_string(h.width) + "x" +
                     std::to_string(h.height) + " needs " +
                     std::to_string(count * bytes_per_sample) + " bytes, file has " +
                     std::to_string(bytes.size() - h.data_offset) + ")");
  }
  ImageU8 image(h.width, h.height, h.channels);
  const auto* src = reinterpret_cast<const uint8_t*>(bytes.data() + h.data_offset);
  if (h.maxval == 255) {
    std::memcpy(image.data.data(), src, count);
    return image;
  }
  for (size_t i = 0; i < count; ++i) {
    // 16-bit samples are big-endian; values above maxval are clamped.
    uint32_t v = bytes_per_sample == 2 ? (uint32_t{src[2 * i]} << 8) | src[2 * i + 1] : src[i];
    v = std::min<uint32_t>(v, h.maxval);
    image.data[i] = static_cast<uint8_t>((v * 255u + h.maxval / 2) / h.maxval);
  }
  return image;
}

// 16-bit gray PGM, values as stored.
Image<uint16_t> readPgm16(const std::string& path) {
  const std::string bytes = internal::readFileBytes(path);
  const PnmHeader h = parsePnmHeader(bytes, path);
  if (h.channels != 1 || h.maxval <= 255) {
    throw InputError(path + ": expected a 16-bit gray PGM (P5, maxval > 255) for a depth map");
  }
  const size_t count = static_cast<size_t>(h.width) * h.height;
  if (bytes.size() - h.data_offset < 2 * count) {
    throw InputError(path + ": truncated PGM data");
  }
  Image<uint16_t> image(h.width, h.height, 1);
  const auto* src = reinterpret_cast<const uint8_t*>(bytes.data() + h.data_offset);
  for (size_t i = 0; i < count; ++i) {
    image.data[i] = static_cast<uint16_t>((src[2 * i] << 8) | src[2 * i + 1]);  // big-endian
  }
  return image;
}

// ---- Header-only sizes -----------------------------------------------------

uint32_t bigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

const uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

bool pngSize(const std::string& head, const std::string& path, int* w, int* h) {
  const auto* p = reinterpret_cast<const uint8_t*>(head.data());
  if (head.size() < 24 || std::memcmp(p + 12, "IHDR", 4) != 0) {
    throw InputError(path + ": corrupt PNG (no IHDR chunk at the start)");
  }
  const uint32_t width = bigEndian32(p + 16);
  const uint32_t height = bigEndian32(p + 20);
  if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide) {
    throw InputError(path + ": corrupt PNG (invalid size " + std::to_string(width) + "x" +
                     std::to_string(height) + ")");
  }
  *w = static_cast<int>(width);
  *h = static_cast<int>(height);
  return true;
}

// Walks the JPEG marker segments up to the first SOFn (frame header).
bool jpegSize(const std::string& path, int* w, int* h) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file for reading");
  auto get = [&]() {
    const int c = in.get();
    if (c == EOF) throw InputError(path + ": truncated JPEG (no frame header found)");
    return c;
  };
  get();
  get();  // SOI, checked by the caller
  for (;;) {
    int c = get();
    if (c != 0xFF) throw InputError(path + ": corrupt JPEG (expected a marker)");
    int marker = get();
    while (marker == 0xFF) marker = get();  // fill bytes
    // Markers without a length field.
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;
    if (marker == 0xD9 || marker == 0xDA) {
      throw InputError(path + ": corrupt JPEG (image data before any frame header)");
    }
    const int length_hi = get();
    const int length = (length_hi << 8) | get();
    if (length < 2) throw InputError(path + ": corrupt JPEG (bad segment length)");
    const bool is_sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                        marker != 0xC8 && marker != 0xCC;
    if (is_sof) {
      if (length < 7) throw InputError(path + ": corrupt JPEG (short frame header)");
      get();  // sample precision
      const int height_hi = get();
      const int height = (height_hi << 8) | get();
      const int width_hi = get();
      const int width = (width_hi << 8) | get();
      if (width == 0) throw InputError(path + ": corrupt JPEG (zero width)");
      if (height == 0) return false;  // height given later by a DNL marker
      *w = width;
      *h = height;
      return true;
    }
    in.seekg(length - 2, std::ios::cur);
    if (!in) throw InputError(path + ": truncated JPEG (no frame header found)");
  }
}

bool bmpSize(const std::string& head, const std::string& path, int* w, int* h) {
  if (head.size() < 26) throw InputError(path + ": truncated BMP header");
  const auto* p = reinterpret_cast<const uint8_t*>(head.data());
  const uint32_t info_size = p[14] | (p[15] << 8) | (p[16] << 16) | (uint32_t{p[17]} << 24);
  if (info_size < 40) return false;  // old OS/2 header: let the decoder size it
  int32_t width, height;
  std::memcpy(&width, p + 18, 4);
  std::memcpy(&height, p + 22, 4);
  if (!internal::isLittleEndianHost()) return false;
  // A negative height means rows stored top-down; widened first, because
  // negating INT32_MIN in 32 bits is undefined.
  const int64_t rows = height < 0 ? -int64_t{height} : int64_t{height};
  if (width <= 0 || rows <= 0 || width > kMaxImageSide || rows > kMaxImageSide) {
    throw InputError(path + ": corrupt BMP (invalid size " + std::to_string(width) + "x" +
                     std::to_string(height) + "; each side must be 1.." +
                     std::to_string(kMaxImageSide) + ")");
  }
  *w = width;
  *h = static_cast<int>(rows);
  return true;
}

std::string readHead(const std::string& path, size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file for reading (missing or unreadable)");
  std::string head(max_bytes, '\0');
  in.read(&head[0], static_cast<std::streamsize>(max_bytes));
  head.resize(static_cast<size_t>(in.gcount()));
  return head;
}

// ---- PNG encoder -----------------------------------------------------------

const std::array<uint32_t, 256>& crcTable() {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  return table;
}

uint32_t crc32(const char* data, size_t size, uint32_t crc = 0) {
  const auto& table = crcTable();
  crc = ~crc;
  for (size_t i = 0; i < size; ++i) {
    crc = table[(crc ^ static_cast<uint8_t>(data[i])) & 0xFF] ^ (crc >> 8);
  }
  return ~crc;
}

uint32_t adler32(const std::string& data) {
  const uint32_t kMod = 65521;
  uint32_t a = 1, b = 0;
  size_t i = 0;
  while (i < data.size()) {
    // 5552 is the longest run before b can overflow 32 bits.
    const size_t end = std::min(data.size(), i + 5552);
    for (; i < end; ++i) {
      a += static_cast<uint8_t>(data[i]);
      b += a;
    }
    a %= kMod;
    b %= kMod;
  }
  return (b << 16) | a;
}

void putBigEndian32(std::string* out, uint32_t v) {
  out->push_back(static_cast<char>(v >> 24));
  out->push_back(static_cast<char>(v >> 16));
  out->push_back(static_cast<char>(v >> 8));
  out->push_back(static_cast<char>(v));
}

void putChunk(std::string* out, const char* type, const char* data, size_t size) {
  putBigEndian32(out, static_cast<uint32_t>(size));
  const size_t start = out->size();
  out->append(type, 4);
  if (size > 0) out->append(data, size);
  putBigEndian32(out, crc32(out->data() + start, size + 4));
}

// zlib stream made of stored (uncompressed) deflate blocks.
std::string zlibStored(const std::string& raw) {
  std::string z;
  z.reserve(raw.size() + raw.size() / 65535 * 5 + 16);
  z.push_back(0x78);  // deflate, 32 KiB window
  z.push_back(0x01);  // no dictionary, fastest; 0x7801 is a multiple of 31
  size_t pos = 0;
  do {
    const size_t len = std::min<size_t>(65535, raw.size() - pos);
    const bool final = pos + len == raw.size();
    z.push_back(final ? 0x01 : 0x00);  // BFINAL, BTYPE=00 (stored)
    z.push_back(static_cast<char>(len & 0xFF));
    z.push_back(static_cast<char>(len >> 8));
    z.push_back(static_cast<char>(~len & 0xFF));
    z.push_back(static_cast<char>((~len >> 8) & 0xFF));
    z.append(raw, pos, len);
    pos += len;
  } while (pos < raw.size());
  putBigEndian32(&z, adler32(raw));
  return z;
}

void checkWritable(const std::string& path, const ImageU8& image, const char* format) {
  if (image.channels != 1 && image.channels != 3) {
    throw InputError(path + ": " + format + " writer takes 1 or 3 channels, image has " +
                     std::to_string(image.channels));
  }
  if (image.width <= 0 || image.height <= 0 ||
      image.data.size() != image.pixelCount() * image.channels) {
    throw InputError(path + ": cannot write an empty or inconsistent image");
  }
}

}  // namespace

const std::vector<std::string>& supportedImageExtensions() {
  static const std::vector<std::string> extensions = {"png", "jpg",  "jpeg", "pgm", "ppm",
                                                      "pnm", "bmp", "tif",  "tiff"};
  return extensions;
}

bool hasImageExtension(const std::string& path) {
  const std::string ext = lowerExtension(path);
  const auto& all = supportedImageExtensions();
  return !ext.empty() && std::find(all.begin(), all.end(), ext) != all.end();
}

bool canDecodeCompressedImages() {
#ifdef AMHMVS_WITH_OPENCV
  return true;
#else
  return false;
#endif
}

#ifdef AMHMVS_WITH_OPENCV
namespace {

// Whether a file starts like one of the compressed formats of
// supportedImageExtensions() (PNG, JPEG, BMP, TIFF). Only those reach OpenCV:
// imread probes every decoder it was built with, and some of those libraries
// abort the process on a corrupt file (GDCM's DICOM reader, found by
// fuzz_image_header) instead of failing.
bool hasCompressedImageSignature(const std::string& head) {
  const auto starts = [&head](const char* magic, size_t size) {
    return head.size() >= size && std::memcmp(head.data(), magic, size) == 0;
  };
  return starts(reinterpret_cast<const char*>(kPngSignature), 8) || starts("\xFF\xD8\xFF", 3) ||
         starts("BM", 2) || starts("II*\0", 4) || starts("MM\0*", 4);
}

// Throws an InputError naming the formats unless the file's first bytes
// (`head`, at least 8 where the file has them) are a compressed format
// OpenCV may decode.
void requireCompressedImageSignature(const std::string& path, const std::string& head) {
  if (!hasCompressedImageSignature(head)) {
    throw InputError(path + ": unrecognised image format (expected PNG, JPEG, BMP, TIFF or binary PGM/PPM)");
  }
}

}  // namespace
#endif

ImageU8 readImage(const std::string& path) {
  const std::string head = readHead(path, 8);
  if (isPnmMagic(head)) return readPnm(path);
#ifdef AMHMVS_WITH_OPENCV
  requireCompressedImageSignature(path, head);
  return internal::readImageOpenCv(path);
#else
  if (!hasImageExtension(path)) {
    throw InputError(path + ": unrecognised image format (expected binary PGM/PPM)");
  }
  throw InputError(path +
                   ": this build has no PNG/JPEG decoder (built without OpenCV); convert the "
                   "image to binary PGM/PPM (e.g. `convert in.png out.ppm`) or rebuild with "
                   "OpenCV");
#endif
}

Image<uint16_t> readImage16(const std::string& path) {
  const std::string head = readHead(path, 8);
  if (isPnmMagic(head)) return readPgm16(path);
#ifdef AMHMVS_WITH_OPENCV
  requireCompressedImageSignature(path, head);
  return internal::readImage16OpenCv(path);
#else
  throw InputError(path + ": this build has no PNG decoder (built without OpenCV); convert the "
                   "depth image to a 16-bit PGM or rebuild with OpenCV");
#endif
}

bool readImageSize(const std::string& path, int* width, int* height) {
  const std::string head = readHead(path, 4096);
  if (head.size() >= 8 && std::memcmp(head.data(), kPngSignature, 8) == 0) {
    return pngSize(head, path, width, height);
  }
  if (head.size() >= 3 && static_cast<uint8_t>(head[0]) == 0xFF &&
      static_cast<uint8_t>(head[1]) == 0xD8 && static_cast<uint8_t>(head[2]) == 0xFF) {
    return jpegSize(path, width, height);
  }
  if (head.size() >= 2 && head[0] == 'B' && head[1] == 'M') {
    return bmpSize(head, path, width, height);
  }
  if (isPnmMagic(head)) {
    // The header may have long comments: retry with the whole file if needed.
    PnmHeader h;
    try {
      h = parsePnmHeader(head, path);
    } catch (const InputError&) {
      if (head.size() < 4096) throw;
      h = parsePnmHeader(internal::readFileBytes(path), path);
    }
    *width = h.width;
    *height = h.height;
    return true;
  }
  return false;
}

void writePnm(const std::string& path, const ImageU8& image) {
  checkWritable(path, image, "PNM");
  std::string bytes = std::string(image.channels == 1 ? "P5" : "P6") + "\n" +
                      std::to_string(image.width) + " " + std::to_string(image.height) +
                      "\n255\n";
  bytes.append(reinterpret_cast<const char*>(image.data.data()), image.data.size());
  writeFileAtomically(path, bytes, "PNM image");
}

void writePng(const std::string& path, const ImageU8& image) {
  checkWritable(path, image, "PNG");
  std::string png(reinterpret_cast<const char*>(kPngSignature), 8);

  char ihdr[13];
  std::string header;
  putBigEndian32(&header, static_cast<uint32_t>(image.width));
  putBigEndian32(&header, static_cast<uint32_t>(image.height));
  std::memcpy(ihdr, header.data(), 8);
  ihdr[8] = 8;                             // bit depth
  ihdr[9] = image.channels == 1 ? 0 : 2;   // colour type: gray or RGB
  ihdr[10] = ihdr[11] = ihdr[12] = 0;      // deflate, adaptive filters, no interlace
  putChunk(&png, "IHDR", ihdr, sizeof(ihdr));

  // Each scanline gets filter type 0 (None).
  const size_t row_bytes = static_cast<size_t>(image.width) * image.channels;
  std::string raw;
  raw.reserve((row_bytes + 1) * image.height);
  for (int y = 0; y < image.height; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(&image.data[y * row_bytes]), row_bytes);
  }
  const std::string z = zlibStored(raw);
  // Several IDAT chunks keep each chunk's length well inside PNG's 2^31-1.
  const size_t kChunk = size_t{1} << 24;
  for (size_t pos = 0; pos < z.size(); pos += kChunk) {
    putChunk(&png, "IDAT", z.data() + pos, std::min(kChunk, z.size() - pos));
  }
  putChunk(&png, "IEND", nullptr, 0);
  writeFileAtomically(path, png, "PNG image");
}

}  // namespace amhmvs
