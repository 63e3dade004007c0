// Decoding of sensor_msgs/CompressedImage (JPEG or PNG, as the official
// compressed_image_transport writes them) into a sensor_msgs/Image in the
// encoding its format string names. Used by this package's `compressed`
// image_transport subscriber (src/ros/compressed_subscriber.cpp).
#pragma once

#include <string>

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

namespace amhmvs_mapping {


// Formats understood:
//   "<encoding>; <jpeg|png> compressed <bgr8|rgb8|...>"  (image_transport_plugins
//   >= 1.9: e.g. "rgb8; jpeg compressed bgr8", "mono8; png compressed "),
//   "jpeg" / "png" (older publishers: mono8 or bgr8 by the channel count).
// The result has the message's header and `<encoding>` (or mono8/mono16/
// bgr8/bgra8 without one). Throws std::runtime_error naming the format when
// the data does not decode or cannot be converted.
sensor_msgs::ImagePtr decodeCompressedImage(const sensor_msgs::CompressedImage& msg);


}  // namespace amhmvs_mapping
