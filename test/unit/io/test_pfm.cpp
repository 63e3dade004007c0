// PFM reading and writing (io/pfm.h).
#include "amhmvs_mapping/io/pfm.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

uint32_t bitsOf(float v) {
  uint32_t b;
  std::memcpy(&b, &v, 4);
  return b;
}

float fromBits(uint32_t b) {
  float v;
  std::memcpy(&v, &b, 4);
  return v;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Special values that a depth map may hold, including a NaN with a payload.
ImageF specialImage(int channels) {
  ImageF image(5, 3, channels);
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            -0.0f,
                            std::numeric_limits<float>::denorm_min(),
                            fromBits(0x7fc12345u),
                            std::numeric_limits<float>::max(),
                            1.0f / 3.0f};
  for (size_t i = 0; i < image.data.size(); ++i) {
    image.data[i] = i < 8 ? specials[i] : static_cast<float>(i) * 0.37f - 2.0f;
  }
  return image;
}

void expectBitExact(const ImageF& a, const ImageF& b) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  ASSERT_EQ(a.channels, b.channels);
  ASSERT_EQ(a.data.size(), b.data.size());
  for (size_t i = 0; i < a.data.size(); ++i) {
    ASSERT_EQ(bitsOf(a.data[i]), bitsOf(b.data[i])) << "value " << i;
  }
}

TEST(Pfm, RoundTripBitExactOneChannel) {
  test::TempDir tmp;
  const ImageF image = specialImage(1);
  writePfm(tmp.file("a.pfm"), image);
  expectBitExact(readPfm(tmp.file("a.pfm")), image);
}

TEST(Pfm, RoundTripBitExactThreeChannels) {
  test::TempDir tmp;
  const ImageF image = specialImage(3);
  writePfm(tmp.file("a.pfm"), image);
  expectBitExact(readPfm(tmp.file("a.pfm")), image);
}

TEST(Pfm, WritesStandardLayoutLittleEndianBottomUp) {
  test::TempDir tmp;
  ImageF image(2, 2, 1);
  image.data = {1.0f, 2.0f, 3.0f, 4.0f};  // top row 1 2, bottom row 3 4
  writePfm(tmp.file("a.pfm"), image);
  const std::string bytes = slurp(tmp.file("a.pfm"));
  const std::string header = "Pf\n2 2\n-1\n";
  ASSERT_EQ(bytes.size(), header.size() + 16);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  // First stored row is the bottom one; 3.0f is 0x40400000 little-endian.
  EXPECT_EQ(bytes.substr(header.size(), 4), std::string("\x00\x00\x40\x40", 4));
  float first;
  std::memcpy(&first, bytes.data() + header.size(), 4);
  EXPECT_EQ(first, 3.0f);
}

TEST(Pfm, ReadsBigEndianAndOneLineHeader) {
  test::TempDir tmp;
  // Positive scale: big-endian. Values 1.5 (0x3FC00000) bottom, -2 (0xC0000000) top.
  const std::string data("\x3F\xC0\x00\x00\xC0\x00\x00\x00", 8);
  const std::string path = tmp.write("be.pfm", std::string("Pf 1 2 1.0\n") + data);
  const ImageF image = readPfm(path);
  ASSERT_EQ(image.width, 1);
  ASSERT_EQ(image.height, 2);
  EXPECT_EQ(image.at(0, 0), -2.0f);
  EXPECT_EQ(image.at(0, 1), 1.5f);
}

TEST(Pfm, ReadsRealMiddleburyDisparity) {
  AMHMVS_REQUIRE_DATA(path, "middlebury2014/Adirondack/disp0GT.pfm");
  const ImageF disp = readPfm(path);  // scale -0.003922: little-endian
  ASSERT_EQ(disp.width, 718);
  ASSERT_EQ(disp.height, 496);
  ASSERT_EQ(disp.channels, 1);
  int inf_count = 0, nan_count = 0;
  float lo = 1e9f, hi = -1e9f;
  for (float v : disp.data) {
    if (std::isinf(v)) ++inf_count;
    if (std::isnan(v)) ++nan_count;
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  // Reference values from an independent (numpy) reader.
  EXPECT_EQ(inf_count, 1210);
  EXPECT_EQ(nan_count, 0);
  EXPECT_NEAR(lo, 9.463028f, 1e-5);
  EXPECT_NEAR(hi, 63.0448f, 1e-4);
  EXPECT_NEAR(disp.at(0, 0), 15.069962f, 1e-5);
  EXPECT_NEAR(disp.at(200, 100), 13.963257f, 1e-5);
  EXPECT_NEAR(disp.at(717, 495), 36.020752f, 1e-5);
}

TEST(Pfm, MalformedInputsNameFileAndProblem) {
  test::TempDir tmp;
  const std::string four_floats(16, '\0');
  EXPECT_INPUT_ERROR(readPfm(tmp.write("magic.pfm", "P5\n2 2\n-1\n" + four_floats)), "magic.pfm",
                     "magic");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("trunc.pfm", "Pf\n2 2\n-1\n" + four_floats.substr(8))),
                     "trunc.pfm", "truncated");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("width.pfm", "Pf\n-2 2\n-1\n" + four_floats)),
                     "width.pfm", "width");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("height.pfm", "Pf\n2 x\n-1\n" + four_floats)),
                     "height.pfm", "height");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("scale.pfm", "Pf\n2 2\n0\n" + four_floats)), "scale.pfm",
                     "scale");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("header.pfm", "Pf\n2")), "header.pfm", "truncated");
  EXPECT_INPUT_ERROR(readPfm(tmp.write("empty.pfm", "")), "empty.pfm", "truncated");
  EXPECT_INPUT_ERROR(readPfm(tmp.file("missing.pfm")), "missing.pfm", "cannot open");
  EXPECT_INPUT_ERROR(writePfm(tmp.file("two.pfm"), ImageF(2, 2, 2)), "two.pfm", "channels");
  EXPECT_INPUT_ERROR(writePfm(tmp.file("nodir/x.pfm"), ImageF(2, 2, 1)), "nodir/x.pfm",
                     "cannot open");
}

}  // namespace
}  // namespace amhmvs
