// libFuzzer target: the nodelet's message conversions (src/ros/ros_conversions.cpp)
// on sensor_msgs/Image, sensor_msgs/CameraInfo and geometry_msgs/Pose filled
// from the input: sizes, steps, encodings and data lengths that disagree,
// NaN and huge values in K/D/P, any quaternion. They return a reason or an
// accepted value; an accepted value must be consistent.
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdlib>
#include <iterator>

#include "amhmvs_mapping/ros/ros_conversions.h"

namespace {

double anyDouble(FuzzedDataProvider* in) {
  // Half the time a plain value near a real camera's, else any bit pattern.
  return in->ConsumeBool() ? in->ConsumeFloatingPointInRange<double>(-2000, 2000)
                           : in->ConsumeFloatingPoint<double>();
}

sensor_msgs::Image image(FuzzedDataProvider* in) {
  static const char* const kEncodings[] = {"mono8", "rgb8", "bgr8", "mono16", "rgba8", "bgra8",
                                           "bayer_rggb8", "bayer_gbrg8", "32FC1", "16UC1", "", "x"};
  sensor_msgs::Image msg;
  msg.width = in->ConsumeIntegral<uint32_t>() % 4096;
  msg.height = in->ConsumeIntegral<uint32_t>() % 4096;
  if (in->ConsumeBool()) msg.width = in->ConsumeIntegral<uint32_t>();
  msg.encoding = kEncodings[in->ConsumeIntegralInRange<size_t>(0, std::size(kEncodings) - 1)];
  // Half the time the step a well-formed message of 1..4 bytes per pixel has.
  msg.step = in->ConsumeBool() ? msg.width * in->ConsumeIntegralInRange<uint32_t>(1, 4)
                               : in->ConsumeIntegral<uint32_t>();
  msg.is_bigendian = in->ConsumeBool();
  const size_t length = in->ConsumeIntegralInRange<size_t>(0, 1 << 16);
  msg.data = in->ConsumeBytes<uint8_t>(length);
  // Half the time the length step x height says (up to 1 MiB), so that
  // well-formed messages reach the decoders.
  const uint64_t declared = uint64_t{msg.step} * msg.height;
  if (in->ConsumeBool() && declared <= (1u << 20)) msg.data.resize(declared);
  return msg;
}

sensor_msgs::CameraInfo cameraInfo(FuzzedDataProvider* in, const sensor_msgs::Image& img) {
  static const char* const kModels[] = {"plumb_bob", "rational_polynomial", "equidistant", "", "x"};
  sensor_msgs::CameraInfo info;
  info.width = in->ConsumeBool() ? img.width : in->ConsumeIntegral<uint32_t>();
  info.height = in->ConsumeBool() ? img.height : in->ConsumeIntegral<uint32_t>();
  info.distortion_model = kModels[in->ConsumeIntegralInRange<size_t>(0, 4)];
  info.D.resize(in->ConsumeIntegralInRange<size_t>(0, 14));
  for (double& d : info.D) d = anyDouble(in);
  for (double& k : info.K) k = anyDouble(in);
  for (double& p : info.P) p = anyDouble(in);
  for (double& r : info.R) r = anyDouble(in);
  return info;
}

geometry_msgs::Pose pose(FuzzedDataProvider* in) {
  geometry_msgs::Pose msg;
  msg.position.x = anyDouble(in);
  msg.position.y = anyDouble(in);
  msg.position.z = anyDouble(in);
  msg.orientation.w = anyDouble(in);
  msg.orientation.x = anyDouble(in);
  msg.orientation.y = anyDouble(in);
  msg.orientation.z = anyDouble(in);
  return msg;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const sensor_msgs::Image img = image(&in);
  amhmvs::ImageU8 decoded;
  if (amhmvs_mapping::imageFromMsg(img, &decoded).empty() &&
      (decoded.width != static_cast<int>(img.width) || decoded.height != static_cast<int>(img.height) ||
       decoded.data.size() != decoded.pixelCount() * decoded.channels)) {
    std::abort();  // accepted, but not the image the message describes
  }
  Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
  if (amhmvs_mapping::poseFromMsg(pose(&in), &camera_to_world).empty() &&
      !camera_to_world.matrix().allFinite()) {
    std::abort();
  }
  const sensor_msgs::CameraInfo info = cameraInfo(&in, img);
  amhmvs::PinholeCamera camera;
  bool distorted = false;
  if (amhmvs_mapping::cameraFromMsg(info, static_cast<int>(img.width), static_cast<int>(img.height),
                                    camera_to_world, &camera, &distorted).empty() &&
      !camera.validate().empty()) {
    std::abort();  // accepted a camera the core refuses
  }
  return 0;
}
