// The tf input mode's pose source: holds each synchronised image +
// camera_info in a tf2_ros::MessageFilter until the transform
// fixed_frame <- image frame at the image's stamp is in the tf2 buffer, then
// hands it on with that pose. Nothing waits inside a callback: the filter
// re-checks when tf data arrives. A frame is given up, with the reason, when
// tf2 says the transform can never come (older than the buffer, empty frame
// id, the filter's queue overflowed) or when it has waited `timeout` seconds
// of wall-clock time (ROS time stands still once a replayed bag ends).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <geometry_msgs/Pose.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

namespace amhmvs_mapping {

class TfFrameFilter {
 public:
  // `camera_to_fixed`: the pose of the image's frame in the fixed frame.
  using Ready = std::function<void(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                                   const geometry_msgs::Pose& camera_to_fixed)>;
  using Missing = std::function<void(const std::string& reason)>;

  // Listens to tf in `nh`; callbacks run on `nh`'s callback queue.
  TfFrameFilter(ros::NodeHandle& nh, const std::string& fixed_frame, double timeout, uint32_t queue_size, Ready ready,
                Missing missing);
  ~TfFrameFilter();  // no callback runs after it

  void add(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info);

 private:
  struct Waiting {
    sensor_msgs::ImageConstPtr image;  // keeps the key's address unique while waiting
    sensor_msgs::CameraInfoConstPtr info;
    ros::WallTime since;
  };

  void transformReady(const sensor_msgs::ImageConstPtr& image);
  void transformFailed(const sensor_msgs::ImageConstPtr& image, tf2_ros::FilterFailureReason reason);
  void expireWaiting();  // wall timer: gives up frames older than the timeout
  // Takes the frame out of the waiting ones; false when it was given up already.
  bool take(const sensor_msgs::Image* image, Waiting* waiting);
  std::string whyNoTransform(const sensor_msgs::Image& image) const;

  std::string fixed_frame_;
  ros::WallDuration timeout_;
  Ready ready_;
  Missing missing_;
  tf2_ros::Buffer buffer_;
  tf2_ros::TransformListener listener_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::Image>> filter_;
  ros::WallTimer expiry_timer_;
  std::mutex mutex_;
  std::map<const sensor_msgs::Image*, Waiting> waiting_;  // by mutex_
};

}  // namespace amhmvs_mapping
