#include "image_io_opencv.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace internal {

namespace {

// imread with errors as InputError naming the file.
cv::Mat decode(const std::string& path, int flags) {
  cv::Mat mat;
  try {
    mat = cv::imread(path, flags);
  } catch (const cv::Exception& e) {
    throw InputError(path + ": image decoding failed (" + e.what() + ")");
  }
  if (mat.empty()) {
    throw InputError(path + ": cannot decode image (unsupported format or corrupt file)");
  }
  return mat;
}

}  // namespace

Image<uint16_t> readImage16OpenCv(const std::string& path) {
  const cv::Mat mat = decode(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_IGNORE_ORIENTATION);
  if (mat.depth() != CV_16U || mat.channels() != 1) {
    throw InputError(path + ": expected a single-channel 16-bit image (a depth map), got " +
                     std::to_string(mat.channels()) + " channel(s) of " +
                     (mat.depth() == CV_8U ? "8" : "non-16") + "-bit samples");
  }
  Image<uint16_t> image(mat.cols, mat.rows, 1);
  for (int y = 0; y < mat.rows; ++y) {
    std::memcpy(&image.data[image.index(0, y)], mat.ptr<uint16_t>(y),
                static_cast<size_t>(mat.cols) * sizeof(uint16_t));
  }
  return image;
}

ImageU8 readImageOpenCv(const std::string& path) {
  // ANYCOLOR keeps gray images single-channel; without ANYDEPTH, 16-bit data is
  // scaled to 8 bits. EXIF orientation is ignored so that the decoded size
  // matches the header size that readImageSize() reports.
  cv::Mat mat = decode(path, cv::IMREAD_ANYCOLOR | cv::IMREAD_IGNORE_ORIENTATION);
  // imread without ANYDEPTH already gives 8 bits; kept as a guard.
  if (mat.depth() == CV_16U) {
    cv::Mat converted;
    mat.convertTo(converted, CV_8U, 1.0 / 257.0);
    mat = converted;
  } else if (mat.depth() != CV_8U) {
    throw InputError(path + ": unsupported sample type (only 8- and 16-bit images are read)");
  }
  // OpenCV orders colour as BGR(A); copy out as RGB by hand so that only the
  // core and imgcodecs modules are needed.
  const int c = mat.channels();
  if (c != 1 && c != 3 && c != 4) {
    throw InputError(path + ": unsupported channel count " + std::to_string(c));
  }
  ImageU8 image(mat.cols, mat.rows, c == 1 ? 1 : 3);
  for (int y = 0; y < mat.rows; ++y) {
    const uint8_t* row = mat.ptr<uint8_t>(y);
    uint8_t* out = &image.data[image.index(0, y)];
    if (c == 1) {
      std::memcpy(out, row, static_cast<size_t>(mat.cols));
      continue;
    }
    for (int x = 0; x < mat.cols; ++x) {
      out[3 * x + 0] = row[c * x + 2];
      out[3 * x + 1] = row[c * x + 1];
      out[3 * x + 2] = row[c * x + 0];
    }
  }
  return image;
}

}  // namespace internal
}  // namespace amhmvs
