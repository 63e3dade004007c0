// Lens undistortion of the nodelet's input images with the ROS camera model:
// image_geometry::PinholeCameraModel and OpenCV's rectification maps (built
// once per camera_info and reused while it stays the same). The output is
// the image the ideal pinhole camera with the same K would have seen (what
// depth/camera_info reports): the model is given R = I and P = [K | 0], so a
// stereo rectification in R and P is not applied.
#pragma once

#include <mutex>

#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/CameraInfo.h>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs_mapping {

class ImageRectifier {
 public:
  // Undistorts `image` in place (nothing to do when D is all zero); its size
  // must be the camera_info's. Throws amhmvs::InputError for a distortion model other
  // than plumb_bob, rational_polynomial or equidistant, or a D that does not
  // fit the model. Thread-safe.
  void undistort(const sensor_msgs::CameraInfo& info, amhmvs::ImageU8* image);

 private:
  std::mutex mutex_;
  image_geometry::PinholeCameraModel model_;  // by mutex_ (caches its maps)
};

}  // namespace amhmvs_mapping
