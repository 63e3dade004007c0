// PGM/PPM/PNG I/O, header-only sizes and extensions (io/image_io.h), plus the
// depth colour map (io/colormap.h).
#include "amhmvs_mapping/io/image_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/colormap.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

using test::randomImage;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

uint32_t be32(const std::string& s, size_t pos) {
  const auto* p = reinterpret_cast<const uint8_t*>(s.data() + pos);
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// Bitwise reference CRC-32 and Adler-32, independent of the encoder's tables.
uint32_t referenceCrc(const std::string& s) {
  uint32_t crc = 0xFFFFFFFFu;
  for (unsigned char c : s) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

uint32_t referenceAdler(const std::string& s) {
  uint64_t a = 1, b = 0;
  for (unsigned char c : s) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  return static_cast<uint32_t>((b << 16) | a);
}

// Decodes a PNG written with stored deflate blocks, checking every CRC, the
// zlib header and the Adler-32; returns the raw (filtered) scanline bytes.
std::string decodeStoredPng(const std::string& png, int* w, int* h, int* color_type) {
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  std::string z;
  size_t pos = 8;
  bool saw_end = false;
  while (pos + 12 <= png.size()) {
    const uint32_t len = be32(png, pos);
    const std::string type = png.substr(pos + 4, 4);
    const std::string data = png.substr(pos + 8, len);
    EXPECT_EQ(be32(png, pos + 8 + len), referenceCrc(type + data)) << "CRC of " << type;
    if (type == "IHDR") {
      *w = static_cast<int>(be32(data, 0));
      *h = static_cast<int>(be32(data, 4));
      EXPECT_EQ(data[8], 8);
      *color_type = data[9];
    } else if (type == "IDAT") {
      z += data;
    } else if (type == "IEND") {
      saw_end = true;
      EXPECT_EQ(be32(png, pos + 8), 0xAE426082u);  // the well-known IEND CRC
    }
    pos += 12 + len;
  }
  EXPECT_TRUE(saw_end);
  EXPECT_EQ(pos, png.size());
  EXPECT_EQ((uint8_t(z[0]) * 256 + uint8_t(z[1])) % 31, 0);
  std::string raw;
  size_t zp = 2;
  for (;;) {
    const uint8_t header = z[zp];
    EXPECT_EQ(header & 0x6, 0) << "not a stored block";
    const unsigned len = uint8_t(z[zp + 1]) | (uint8_t(z[zp + 2]) << 8);
    const unsigned nlen = uint8_t(z[zp + 3]) | (uint8_t(z[zp + 4]) << 8);
    EXPECT_EQ(len ^ 0xFFFFu, nlen);
    raw += z.substr(zp + 5, len);
    zp += 5 + len;
    if (header & 1) break;
  }
  EXPECT_EQ(zp + 4, z.size());
  EXPECT_EQ(be32(z, zp), referenceAdler(raw));
  return raw;
}

TEST(ImageIo, Extensions) {
  EXPECT_TRUE(hasImageExtension("a/b/00000001.png"));
  EXPECT_TRUE(hasImageExtension("x.JPG"));
  EXPECT_TRUE(hasImageExtension("x.Jpeg"));
  for (const char* ext : {"pgm", "ppm", "pnm", "bmp", "tif", "TIFF"}) {
    EXPECT_TRUE(hasImageExtension(std::string("img.") + ext)) << ext;
  }
  EXPECT_FALSE(hasImageExtension("cam.txt"));
  EXPECT_FALSE(hasImageExtension("png"));
  EXPECT_FALSE(hasImageExtension("dir.png/file"));
  EXPECT_FALSE(hasImageExtension("x.png.bak"));
  EXPECT_EQ(supportedImageExtensions().size(), 9u);
}

TEST(ImageIo, PnmRoundTrip) {
  test::TempDir tmp;
  for (int c : {1, 3}) {
    const ImageU8 image = randomImage(13, 7, c, 10 + c);
    const std::string path = tmp.file(c == 1 ? "a.pgm" : "a.ppm");
    writePnm(path, image);
    const ImageU8 back = readImage(path);
    EXPECT_EQ(back.width, 13);
    EXPECT_EQ(back.height, 7);
    EXPECT_EQ(back.channels, c);
    EXPECT_EQ(back.data, image.data);
    int w = 0, h = 0;
    EXPECT_TRUE(readImageSize(path, &w, &h));
    EXPECT_EQ(w, 13);
    EXPECT_EQ(h, 7);
  }
}

TEST(ImageIo, PnmHeaderCommentsAndMaxvals) {
  test::TempDir tmp;
  const ImageU8 a =
      readImage(tmp.write("c.pgm", "P5\n# made by hand\n2 # width\n1\n255\n\x07\xF0"));
  ASSERT_EQ(a.width, 2);
  EXPECT_EQ(a.data, (std::vector<uint8_t>{7, 240}));
  // maxval 15 is stretched to 0..255.
  const ImageU8 b = readImage(tmp.write("m.pgm", std::string("P5 3 1 15 \x00\x0F\x07", 13)));
  EXPECT_EQ(b.data, (std::vector<uint8_t>{0, 255, 119}));
  // 16-bit big-endian samples are scaled down.
  const ImageU8 c =
      readImage(tmp.write("w.pgm", std::string("P5 2 1 65535\n\xFF\xFF\x80\x00", 17)));
  EXPECT_EQ(c.data, (std::vector<uint8_t>{255, 128}));
}

TEST(ImageIo, PngEncoderProducesValidStoredPng) {
  test::TempDir tmp;
  // Wide enough that the zlib stream needs several stored blocks (> 65535 bytes).
  for (auto [w, h, c] : {std::make_tuple(3, 2, 1), std::make_tuple(301, 77, 3),
                         std::make_tuple(200, 200, 1)}) {
    const ImageU8 image = randomImage(w, h, c, w * 7 + c);
    const std::string path = tmp.file("p.png");
    writePng(path, image);
    int pw = 0, ph = 0, color = -1;
    const std::string raw = decodeStoredPng(slurp(path), &pw, &ph, &color);
    EXPECT_EQ(pw, w);
    EXPECT_EQ(ph, h);
    EXPECT_EQ(color, c == 1 ? 0 : 2);
    std::string expected;
    for (int y = 0; y < h; ++y) {
      expected.push_back('\0');
      expected.append(reinterpret_cast<const char*>(&image.data[image.index(0, y)]),
                      static_cast<size_t>(w) * c);
    }
    EXPECT_EQ(raw, expected);
    int sw = 0, sh = 0;
    EXPECT_TRUE(readImageSize(path, &sw, &sh));
    EXPECT_EQ(sw, w);
    EXPECT_EQ(sh, h);
  }
}

// readImage decodes PNG through OpenCV (libpng) in OpenCV builds: an
// independent decoder for our encoder.
TEST(ImageIo, PngDecodesToInputWithOpenCv) {
  if (!canDecodeCompressedImages()) GTEST_SKIP() << "built without OpenCV";
  test::TempDir tmp;
  for (int c : {1, 3}) {
    const ImageU8 image = randomImage(257, 131, c, 20 + c);
    const std::string path = tmp.file("p.png");
    writePng(path, image);
    const ImageU8 back = readImage(path);
    EXPECT_EQ(back.channels, c);
    EXPECT_EQ(back.width, 257);
    EXPECT_EQ(back.data, image.data);
  }
  // Channel order is RGB: a pure red image stays red.
  ImageU8 red(4, 4, 3);
  for (size_t i = 0; i < red.data.size(); i += 3) red.data[i] = 255;
  writePng(tmp.file("red.png"), red);
  const ImageU8 back = readImage(tmp.file("red.png"));
  EXPECT_EQ(back.at(1, 1, 0), 255);
  EXPECT_EQ(back.at(1, 1, 2), 0);
}

// Only PNG, JPEG, BMP and TIFF files reach OpenCV's decoders: the fuzzer's
// file (a bad PNM magic, then bytes that OpenCV handed to GDCM's DICOM
// reader, which aborted the process) and other formats are refused by name.
TEST(ImageIo, FilesOfOtherFormatsNeverReachTheDecoders) {
  if (!canDecodeCompressedImages()) GTEST_SKIP() << "built without OpenCV";
  test::TempDir tmp;
  std::string dicom_like = "P" + std::string(103, '\xf9') + "6\n#1\xff" + "6\n #1? \xf7" + std::string(1, '\0') +
                           "\x02" + std::string(1, '\0') + "DCAP)VEC";
  dicom_like += std::string("DICMT") + '\0' + "=";  // DICOM's magic at byte 128
  const std::string dicom_preamble = std::string(128, '\0') + "DICM" + std::string(64, '\x01');
  const std::string exr = std::string("\x76\x2f\x31\x01") + std::string(60, '\0');
  for (const auto& [name, bytes] : {std::pair<std::string, std::string>{"fuzzed.png", dicom_like},
                                    {"scan.dcm", dicom_preamble}, {"light.exr", exr}}) {
    const std::string path = tmp.write(name, bytes);
    EXPECT_INPUT_ERROR(readImage(path), name, "unrecognised image format (expected PNG, JPEG, BMP, TIFF");
    EXPECT_INPUT_ERROR(readImage16(path), name, "unrecognised image format");
  }
  // A real PNG still decodes (the signature gate lets it through).
  writePng(tmp.file("ok.png"), ImageU8(3, 2, 1, 7));
  EXPECT_EQ(readImage(tmp.file("ok.png")).width, 3);
}

TEST(ImageIo, WithoutOpenCvPngIsAClearError) {
  if (canDecodeCompressedImages()) GTEST_SKIP() << "built with OpenCV";
  test::TempDir tmp;
  writePng(tmp.file("p.png"), ImageU8(2, 2, 1));
  EXPECT_INPUT_ERROR(readImage(tmp.file("p.png")), "p.png", "no PNG/JPEG decoder");
}

TEST(ImageIo, HeaderSizesOfRealFiles) {
  AMHMVS_REQUIRE_DATA(jpg, "strecha/fountain-P11/images/0000.jpg");
  AMHMVS_REQUIRE_DATA(png, "mvsnet/fountain_x0.25/images/00000000.png");
  int w = 0, h = 0;
  ASSERT_TRUE(readImageSize(jpg, &w, &h));
  EXPECT_EQ(w, 3072);
  EXPECT_EQ(h, 2048);
  ASSERT_TRUE(readImageSize(png, &w, &h));
  EXPECT_EQ(w, 768);
  EXPECT_EQ(h, 512);
  if (canDecodeCompressedImages()) {
    const ImageU8 image = readImage(png);
    EXPECT_EQ(image.width, 768);
    EXPECT_EQ(image.height, 512);
    EXPECT_EQ(image.channels, 3);
  }
}

TEST(ImageIo, HeaderSizesOfBmpAndUnknownFormats) {
  test::TempDir tmp;
  // 54-byte BMP header of a 5x-3 (top-down) image; pixel data is not needed.
  std::string bmp(54, '\0');
  bmp[0] = 'B';
  bmp[1] = 'M';
  bmp[14] = 40;
  const int32_t width = 5, height = -3;
  std::memcpy(&bmp[18], &width, 4);
  std::memcpy(&bmp[22], &height, 4);
  int w = 0, h = 0;
  ASSERT_TRUE(readImageSize(tmp.write("a.bmp", bmp), &w, &h));
  EXPECT_EQ(w, 5);
  EXPECT_EQ(h, 3);
  EXPECT_FALSE(readImageSize(tmp.write("a.tif", "II*\0 not parsed here"), &w, &h));
  EXPECT_INPUT_ERROR(readImageSize(tmp.write("bad.png", std::string("\x89PNG\r\n\x1a\n", 8)), &w,
                                   &h),
                     "bad.png", "corrupt PNG");
  EXPECT_INPUT_ERROR(readImageSize(tmp.write("bad.jpg", std::string("\xFF\xD8\xFF\xE0\x00\x10", 6)),
                                   &w, &h),
                     "bad.jpg", "truncated JPEG");
  EXPECT_INPUT_ERROR(readImageSize(tmp.file("none.png"), &w, &h), "none.png", "cannot open");
}

// BMP sizes: INT32_MIN rows (whose negation in 32 bits is undefined) and
// sides above kMaxImageSide are refused with the size in the message.
TEST(ImageIo, BmpSizesOutOfRangeAreRefused) {
  test::TempDir tmp;
  auto bmp_header = [](int32_t width, int32_t height) {
    std::string bmp(54, '\0');
    bmp[0] = 'B';
    bmp[1] = 'M';
    bmp[14] = 40;
    std::memcpy(&bmp[18], &width, 4);
    std::memcpy(&bmp[22], &height, 4);
    return bmp;
  };
  int w = 0, h = 0;
  EXPECT_INPUT_ERROR(readImageSize(tmp.write("min.bmp", bmp_header(8, INT32_MIN)), &w, &h),
                     "min.bmp", "invalid size 8x-2147483648");
  EXPECT_INPUT_ERROR(readImageSize(tmp.write("wide.bmp", bmp_header(2000000, 10)), &w, &h),
                     "wide.bmp", "invalid size 2000000x10; each side must be 1..1048576");
  ASSERT_TRUE(readImageSize(tmp.write("max.bmp", bmp_header(kMaxImageSide, -kMaxImageSide)), &w,
                            &h));
  EXPECT_EQ(h, kMaxImageSide);
}

TEST(ImageIo, MalformedPnmNamesFileAndProblem) {
  test::TempDir tmp;
  EXPECT_INPUT_ERROR(readImage(tmp.write("t.pgm", "P5\n4 4\n255\n\x01\x02")), "t.pgm",
                     "truncated");
  EXPECT_INPUT_ERROR(readImage(tmp.write("a.pgm", "P2\n1 1\n255\n7\n")), "a.pgm", "P2");
  EXPECT_INPUT_ERROR(readImage(tmp.write("w.pgm", "P5\n0 4\n255\n")), "w.pgm", "width");
  EXPECT_INPUT_ERROR(readImage(tmp.write("m.ppm", "P6\n1 1\n70000\n\x01\x02\x03")), "m.ppm",
                     "maxval");
  EXPECT_INPUT_ERROR(readImage(tmp.file("missing.ppm")), "missing.ppm", "cannot open");
  EXPECT_INPUT_ERROR(writePng(tmp.file("two.png"), ImageU8(2, 2, 2)), "two.png", "channels");
  EXPECT_INPUT_ERROR(writePnm(tmp.file("no/dir.pgm"), ImageU8(2, 2, 1)), "no/dir.pgm",
                     "cannot open");
}

TEST(Colormap, EndpointsMiddleAndInvalidPixels) {
  ImageF depth(5, 1, 1);
  depth.data = {1.0f, 3.0f, 5.0f, std::numeric_limits<float>::quiet_NaN(),
                std::numeric_limits<float>::infinity()};
  const ImageU8 rgb = colorizeDepth(depth, 1.0f, 5.0f);
  ASSERT_EQ(rgb.channels, 3);
  // viridis(0) = #440154, viridis(0.5) = #21918c, NaN/inf black.
  EXPECT_EQ(rgb.at(0, 0, 0), 0x44);
  EXPECT_EQ(rgb.at(0, 0, 1), 0x01);
  EXPECT_EQ(rgb.at(0, 0, 2), 0x54);
  EXPECT_EQ(rgb.at(1, 0, 0), 0x21);
  EXPECT_EQ(rgb.at(1, 0, 1), 0x91);
  EXPECT_EQ(rgb.at(2, 0, 0), 0xfd);
  EXPECT_EQ(rgb.at(2, 0, 2), 0x25);
  for (int x = 3; x < 5; ++x) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(rgb.at(x, 0, c), 0);
  }
  // Brightness grows monotonically along the map (perceptual ordering).
  ImageF ramp(101, 1, 1);
  for (int x = 0; x <= 100; ++x) ramp.data[x] = static_cast<float>(x);
  const ImageU8 r = colorizeDepth(ramp, 0, 100);
  const ImageU8 luma = toGray(r);
  for (int x = 1; x <= 100; ++x) EXPECT_GE(luma.data[x], luma.data[x - 1]) << x;
  EXPECT_THROW(colorizeDepth(depth, 5.0f, 1.0f), InputError);
  EXPECT_THROW(colorizeDepth(depth, 0.0f, std::numeric_limits<float>::infinity()), InputError);
  EXPECT_THROW(colorizeDepth(ImageF(2, 2, 3), 0, 1), InputError);
}

TEST(Colormap, RobustRangeOverFiniteValues) {
  ImageF image(103, 1, 1);
  for (int i = 0; i < 101; ++i) image.data[i] = static_cast<float>(100 - i);  // 0..100
  image.data[101] = std::numeric_limits<float>::quiet_NaN();
  image.data[102] = -std::numeric_limits<float>::infinity();
  const auto range = robustRange(image);
  EXPECT_FLOAT_EQ(range.first, 2.0f);
  EXPECT_FLOAT_EQ(range.second, 98.0f);
  const auto full = robustRange(image, 0.0, 1.0);
  EXPECT_FLOAT_EQ(full.first, 0.0f);
  EXPECT_FLOAT_EQ(full.second, 100.0f);
  EXPECT_FLOAT_EQ(robustRange(image, 0.005, 0.5).first, 0.5f);  // interpolated
  ImageF empty(2, 1, 1, std::numeric_limits<float>::quiet_NaN());
  EXPECT_INPUT_ERROR(robustRange(empty), "robustRange", "no finite");
  EXPECT_THROW(robustRange(image, 0.9, 0.1), InputError);
}

// The selection gives exactly the quantiles of the sorted values (ties and
// repeated values included), for any pair of fractions.
TEST(Colormap, RobustRangeEqualsSortedQuantiles) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> level(0, 500);  // many repeated values
  ImageF image(317, 29, 1);
  for (float& v : image.data) v = 0.01f * static_cast<float>(level(rng));
  for (size_t i = 0; i < image.data.size(); i += 17) image.data[i] = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> sorted;
  for (float v : image.data) {
    if (std::isfinite(v)) sorted.push_back(v);
  }
  std::sort(sorted.begin(), sorted.end());
  auto quantile = [&](double p) {
    const double pos = p * static_cast<double>(sorted.size() - 1);
    const size_t lo = static_cast<size_t>(std::floor(pos));
    const size_t hi = std::min(sorted.size() - 1, lo + 1);
    return static_cast<float>(sorted[lo] + (pos - lo) * (static_cast<double>(sorted[hi]) - sorted[lo]));
  };
  for (const auto& fractions : {std::pair<double, double>{0.02, 0.98}, {0.0, 1.0}, {0.3337, 0.3338}, {0.5, 0.5}}) {
    const auto range = robustRange(image, fractions.first, fractions.second);
    EXPECT_EQ(range.first, quantile(fractions.first)) << fractions.first;
    EXPECT_EQ(range.second, quantile(fractions.second)) << fractions.second;
  }
}

}  // namespace
}  // namespace amhmvs
