#include "amhmvs_mapping/ros/compressed_image_decoder.h"

#include <stdexcept>

#include <cv_bridge/cv_bridge.h>
#include <opencv2/imgcodecs.hpp>
#include <sensor_msgs/image_encodings.h>

#include "amhmvs_mapping/core/text.h"

namespace amhmvs_mapping {

namespace enc = sensor_msgs::image_encodings;

namespace {

// The encoding of what cv::imdecode returned: OpenCV's BGR order, unless the
// publisher compressed the bytes as "rgb" (then they come back in RGB order).
std::string decodedEncoding(const cv::Mat& image, bool rgb_order) {
  const bool sixteen = image.depth() == CV_16U;
  switch (image.channels()) {
    case 1: return sixteen ? enc::MONO16 : enc::MONO8;
    case 3: return rgb_order ? (sixteen ? enc::RGB16 : enc::RGB8) : (sixteen ? enc::BGR16 : enc::BGR8);
    case 4: return rgb_order ? (sixteen ? enc::RGBA16 : enc::RGBA8) : (sixteen ? enc::BGRA16 : enc::BGRA8);
    default: return "";
  }
}

}  // namespace

sensor_msgs::ImagePtr decodeCompressedImage(const sensor_msgs::CompressedImage& msg) {
  const std::string& format = msg.format;
  const auto split = format.find(';');
  const std::string wanted = split == std::string::npos ? "" : amhmvs::trimmed(format.substr(0, split));
  const std::string compression = split == std::string::npos ? format : format.substr(split + 1);
  const bool rgb_order = compression.find("compressed rgb") != std::string::npos;

  cv::Mat decoded;
  if (!msg.data.empty()) decoded = cv::imdecode(cv::Mat(msg.data), cv::IMREAD_UNCHANGED);
  if (decoded.empty())
    throw std::runtime_error("compressed image (format '" + format + "', " + std::to_string(msg.data.size()) +
                             " bytes): not a JPEG or PNG that OpenCV decodes");
  const std::string have = decodedEncoding(decoded, rgb_order);
  if (have.empty())
    throw std::runtime_error("compressed image (format '" + format + "'): " + std::to_string(decoded.channels()) +
                             " channels decoded");
  cv_bridge::CvImage image(msg.header, have, decoded);
  if (wanted.empty() || wanted == have) return image.toImageMsg();
  try {
    return cv_bridge::cvtColor(cv_bridge::CvImagePtr(new cv_bridge::CvImage(image)), wanted)->toImageMsg();
  } catch (const cv_bridge::Exception& e) {
    throw std::runtime_error("compressed image (format '" + format + "'): cannot convert " + have + " to " +
                             wanted + ": " + e.what());
  }
}

}  // namespace amhmvs_mapping
