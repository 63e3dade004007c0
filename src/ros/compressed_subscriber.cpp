// The `compressed` image_transport subscriber (sensor_msgs/CompressedImage on
// <base topic>/compressed, JPEG or PNG), for `~image_transport: compressed`.
// Why here: Debian 12's ROS packages have image_transport's raw plugins only
// (no image_transport_plugins / compressed_image_transport), so a bag recorded
// with compressed images could not be mapped. With the official plugin
// installed, build with -DAMHMVS_COMPRESSED_PLUGIN=OFF (README).
#include <image_transport/simple_subscriber_plugin.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/console.h>
#include <sensor_msgs/CompressedImage.h>

#include "amhmvs_mapping/ros/compressed_image_decoder.h"

namespace amhmvs_mapping {

class CompressedSubscriber : public image_transport::SimpleSubscriberPlugin<sensor_msgs::CompressedImage> {
 public:
  std::string getTransportName() const override { return "compressed"; }

 protected:
  void internalCallback(const sensor_msgs::CompressedImageConstPtr& msg, const Callback& user_cb) override {
    sensor_msgs::ImagePtr image;
    try {
      image = decodeCompressedImage(*msg);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5.0, "%s: %s", getTopic().c_str(), e.what());
      return;
    }
    user_cb(image);
  }
};

}  // namespace amhmvs_mapping

PLUGINLIB_EXPORT_CLASS(amhmvs_mapping::CompressedSubscriber, image_transport::SubscriberPlugin)
