#include "amhmvs_mapping/ros/image_rectifier.h"

#include <opencv2/core.hpp>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/undistortion.h"

namespace amhmvs_mapping {
namespace {

// The camera_info as the model should see it: D checked and padded to the
// model's length (OpenCV takes only full lengths), the output camera the
// raw one's K (no rectifying rotation, no ROI or binning).
sensor_msgs::CameraInfo undistortionInfo(const sensor_msgs::CameraInfo& info, amhmvs::Distortion* distortion) {
  const std::string problem = amhmvs::parseDistortion(info.distortion_model, info.D, distortion);
  if (!problem.empty()) throw amhmvs::InputError(problem);
  sensor_msgs::CameraInfo model_info;
  model_info.header = info.header;
  model_info.width = info.width;
  model_info.height = info.height;
  model_info.distortion_model = info.distortion_model.empty() ? "plumb_bob" : info.distortion_model;
  model_info.D = distortion->coefficients;
  model_info.K = info.K;
  model_info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  model_info.P = {info.K[0], info.K[1], info.K[2], 0, info.K[3], info.K[4], info.K[5], 0, 0, 0, 1, 0};
  return model_info;
}

}  // namespace

void ImageRectifier::undistort(const sensor_msgs::CameraInfo& info, amhmvs::ImageU8* raw_image) {
  amhmvs::Distortion distortion;
  const sensor_msgs::CameraInfo model_info = undistortionInfo(info, &distortion);
  if (distortion.isZero()) return;
  amhmvs::ImageU8& image = *raw_image;
  if (image.width != static_cast<int>(info.width) || image.height != static_cast<int>(info.height))
    throw amhmvs::InputError("image size does not match camera_info");
  const int type = CV_8UC(image.channels);
  const cv::Mat raw(image.height, image.width, type, image.data.data());  // no copy
  amhmvs::ImageU8 out(image.width, image.height, image.channels, 0);
  cv::Mat rectified(out.height, out.width, type, out.data.data());
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    model_.fromCameraInfo(model_info);  // keeps its maps when nothing changed
    model_.rectifyImage(raw, rectified, cv::INTER_LINEAR);
  } catch (const image_geometry::Exception& e) {
    throw amhmvs::InputError(std::string("image_geometry: ") + e.what());
  } catch (const cv::Exception& e) {
    throw amhmvs::InputError(std::string("OpenCV: ") + e.what());
  }
  if (rectified.data != out.data.data()) throw amhmvs::InputError("rectified image has an unexpected layout");
  *raw_image = std::move(out);
}

}  // namespace amhmvs_mapping
