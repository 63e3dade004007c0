// The compressed transport's decoder: PNG round trips exactly in the
// encoding the format names (rgb8 from "compressed bgr8", mono8, old "png"
// formats, 16-bit mono), JPEG within its loss; garbage is an error naming
// the format.
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <sensor_msgs/image_encodings.h>

#include "amhmvs_mapping/ros/compressed_image_decoder.h"

namespace amhmvs_mapping {
namespace {

namespace enc = sensor_msgs::image_encodings;

// A 8x6 colour ramp in BGR order (what the official publisher encodes).
cv::Mat bgrRamp() {
  cv::Mat image(6, 8, CV_8UC3);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<cv::Vec3b>(y, x) = cv::Vec3b(10 * x, 20 * y, 200 - 5 * x);
  return image;
}

sensor_msgs::CompressedImage compressed(const cv::Mat& image, const std::string& extension,
                                        const std::string& format) {
  sensor_msgs::CompressedImage msg;
  msg.header.frame_id = "camera_optical";
  msg.header.stamp = ros::Time(12, 34);
  msg.format = format;
  std::vector<uchar> bytes;
  EXPECT_TRUE(cv::imencode(extension, image, bytes));
  msg.data = bytes;
  return msg;
}

TEST(CompressedImageDecoder, PngRgb8FromCompressedBgr8IsExact) {
  const cv::Mat bgr = bgrRamp();
  const sensor_msgs::ImagePtr image = decodeCompressedImage(compressed(bgr, ".png", "rgb8; png compressed bgr8"));
  EXPECT_EQ(image->encoding, enc::RGB8);
  EXPECT_EQ(image->header.frame_id, "camera_optical");
  EXPECT_EQ(image->header.stamp, ros::Time(12, 34));
  ASSERT_EQ(image->width, 8u);
  ASSERT_EQ(image->height, 6u);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      const uint8_t* rgb = &image->data[y * image->step + 3 * x];
      const cv::Vec3b expected = bgr.at<cv::Vec3b>(y, x);
      EXPECT_EQ(rgb[0], expected[2]);
      EXPECT_EQ(rgb[1], expected[1]);
      EXPECT_EQ(rgb[2], expected[0]);
    }
}

TEST(CompressedImageDecoder, MonoAndOldFormatsByChannelCount) {
  cv::Mat grey(4, 5, CV_8UC1, cv::Scalar(77));
  sensor_msgs::ImagePtr image = decodeCompressedImage(compressed(grey, ".png", "mono8; png compressed "));
  EXPECT_EQ(image->encoding, enc::MONO8);
  EXPECT_EQ(image->data[7], 77);
  EXPECT_EQ(decodeCompressedImage(compressed(grey, ".png", "png"))->encoding, enc::MONO8);
  EXPECT_EQ(decodeCompressedImage(compressed(bgrRamp(), ".jpg", "jpeg"))->encoding, enc::BGR8);
}

TEST(CompressedImageDecoder, SixteenBitPngStaysMono16) {
  cv::Mat depth(3, 4, CV_16UC1, cv::Scalar(54321));
  const sensor_msgs::ImagePtr image = decodeCompressedImage(compressed(depth, ".png", "mono16; png compressed "));
  EXPECT_EQ(image->encoding, enc::MONO16);
  ASSERT_EQ(image->step, 8u);
  uint16_t value = 0;
  std::memcpy(&value, &image->data[2 * image->step + 6], 2);
  EXPECT_EQ(value, 54321);
}

TEST(CompressedImageDecoder, JpegBgr8WithinItsLoss) {
  const cv::Mat bgr = bgrRamp();
  const sensor_msgs::ImagePtr image = decodeCompressedImage(compressed(bgr, ".jpg", "bgr8; jpeg compressed bgr8"));
  EXPECT_EQ(image->encoding, enc::BGR8);
  const cv::Mat decoded(6, 8, CV_8UC3, image->data.data(), image->step);
  EXPECT_LT(cv::norm(decoded, bgr, cv::NORM_INF), 40);
}

TEST(CompressedImageDecoder, GarbageNamesTheFormat) {
  sensor_msgs::CompressedImage msg;
  msg.format = "rgb8; jpeg compressed bgr8";
  msg.data = {1, 2, 3};
  try {
    decodeCompressedImage(msg);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("rgb8; jpeg compressed bgr8"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amhmvs_mapping
