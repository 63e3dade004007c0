#include "image_io_opencv.h"

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace internal {

ImageU8 readImageOpenCv(const std::string& path) {
  // ANYCOLOR keeps gray images single-channel; without ANYDEPTH, 16-bit data is
  // scaled to 8 bits. EXIF orientation is ignored so that the decoded size
  // matches the header size that readImageSize() reports.
  cv::Mat mat;
  try {
    mat = cv::imread(path, cv::IMREAD_ANYCOLOR | cv::IMREAD_IGNORE_ORIENTATION);
  } catch (const cv::Exception& e) {
    throw InputError(path + ": image decoding failed (" + e.what() + ")");
  }
  if (mat.empty()) {
    throw InputError(path + ": cannot decode image (unsupported format or corrupt file)");
  }
  if (mat.depth() != CV_8U) {
    cv::Mat converted;
    mat.convertTo(converted, CV_8U);
    mat = converted;
  }
  cv::Mat out;
  switch (mat.channels()) {
    case 1:
      out = mat;
      break;
    case 3:
      cv::cvtColor(mat, out, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(mat, out, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw InputError(path + ": unsupported channel count " + std::to_string(mat.channels()));
  }
  if (!out.isContinuous()) out = out.clone();
  ImageU8 image(out.cols, out.rows, out.channels());
  std::memcpy(image.data.data(), out.data, image.data.size());
  return image;
}

}  // namespace internal
}  // namespace amhmvs
