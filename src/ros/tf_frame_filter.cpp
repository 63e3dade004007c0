#include "amhmvs_mapping/ros/tf_frame_filter.h"

#include <sstream>
#include <vector>

#include <tf2_eigen/tf2_eigen.h>

namespace amhmvs_mapping {
namespace {
// How often waiting frames are checked against the timeout: a frame is given
// up between `timeout` and `timeout` + this.
constexpr double kExpiryCheckPeriod = 0.02;

const char* failureName(tf2_ros::FilterFailureReason reason) {
  switch (reason) {
    case tf2_ros::filter_failure_reasons::OutTheBack: return "older than the tf buffer";
    case tf2_ros::filter_failure_reasons::EmptyFrameID: return "the image has no frame_id";
    default: return "tf message filter queue full or transform lost";
  }
}
}  // namespace

TfFrameFilter::TfFrameFilter(ros::NodeHandle& nh, const std::string& fixed_frame, double timeout, uint32_t queue_size,
                             Ready ready, Missing missing)
    : fixed_frame_(fixed_frame),
      timeout_(timeout),
      ready_(std::move(ready)),
      missing_(std::move(missing)),
      listener_(buffer_, nh) {
  filter_.reset(new tf2_ros::MessageFilter<sensor_msgs::Image>(buffer_, fixed_frame_, queue_size, nh));
  filter_->registerCallback(
      boost::function<void(const sensor_msgs::ImageConstPtr&)>([this](const sensor_msgs::ImageConstPtr& image) {
        transformReady(image);
      }));
  filter_->registerFailureCallback(
      [this](const sensor_msgs::ImageConstPtr& image, tf2_ros::FilterFailureReason reason) {
        transformFailed(image, reason);
      });
  expiry_timer_ = nh.createWallTimer(ros::WallDuration(kExpiryCheckPeriod),
                                     [this](const ros::WallTimerEvent&) { expireWaiting(); });
}

TfFrameFilter::~TfFrameFilter() {
  expiry_timer_.stop();
  filter_.reset();  // removes its queued callbacks
}

void TfFrameFilter::add(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    waiting_[image.get()] = {image, info, ros::WallTime::now()};
  }
  filter_->add(image);
}

bool TfFrameFilter::take(const sensor_msgs::Image* image, Waiting* waiting) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = waiting_.find(image);
  if (it == waiting_.end()) return false;
  *waiting = std::move(it->second);
  waiting_.erase(it);
  return true;
}

void TfFrameFilter::transformReady(const sensor_msgs::ImageConstPtr& image) {
  Waiting waiting;
  if (!take(image.get(), &waiting)) return;  // given up after the timeout
  geometry_msgs::TransformStamped transform;
  try {
    transform = buffer_.lookupTransform(fixed_frame_, image->header.frame_id, image->header.stamp);
  } catch (const tf2::TransformException& e) {
    missing_(e.what());
    return;
  }
  ready_(waiting.image, waiting.info, tf2::toMsg(tf2::transformToEigen(transform)));
}

void TfFrameFilter::transformFailed(const sensor_msgs::ImageConstPtr& image, tf2_ros::FilterFailureReason reason) {
  Waiting waiting;
  if (!take(image.get(), &waiting)) return;
  missing_(std::string(failureName(reason)) + ": " + whyNoTransform(*image));
}

void TfFrameFilter::expireWaiting() {
  std::vector<sensor_msgs::ImageConstPtr> expired;
  {
    const ros::WallTime now = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = waiting_.begin(); it != waiting_.end();) {
      if (now - it->second.since < timeout_) {
        ++it;
        continue;
      }
      expired.push_back(it->second.image);
      it = waiting_.erase(it);
    }
  }
  for (const sensor_msgs::ImageConstPtr& image : expired) {
    std::ostringstream reason;
    reason << "not within ~tf_timeout " << timeout_.toSec() << " s: " << whyNoTransform(*image);
    missing_(reason.str());
  }
}

std::string TfFrameFilter::whyNoTransform(const sensor_msgs::Image& image) const {
  std::string error;
  if (buffer_.canTransform(fixed_frame_, image.header.frame_id, image.header.stamp, &error)) return "it came late";
  return "no transform " + fixed_frame_ + " <- '" + image.header.frame_id + "': " + error;
}

}  // namespace amhmvs_mapping
