// Inputs of the mapping nodelet, by ~input_mode:
//   pose:     image (image_transport) + camera_info + pose (PoseStamped,
//             camera-to-world of the optical frame), approximate-time synced;
//   odometry: the same with odom (nav_msgs/Odometry) instead of pose;
//   tf:       image + camera_info, pose from tf2: fixed_frame <- image frame
//             (TfFrameFilter: held until the transform is there, no waiting);
//   keyframe: keyframe (amhmvs_mapping/Keyframe);
// and, in every mode, keyframe_poses (KeyframePoses: loop-closure updates).
// In pose, odometry and tf modes the core KeyframePicker decides which frames
// become keyframes: moved at least ~keyframe_min_translation or turned at
// least ~keyframe_min_rotation_deg from the last keyframe, and neither a pure
// rotation nor blurred (keyframe_picker.h).
//
// Each accepted keyframe is checked (encoding, pose, camera_info, stamp
// order), converted to a core Keyframe (grey or RGB, undistorted to the
// pinhole with the same K, downscaled to ~max_image_size) and handed to the
// `keyframe` callback with its header (stamp, optical frame). Dropped input is
// counted by reason (InputStats) and reported, throttled per reason.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>

#include "amhmvs_mapping/Keyframe.h"
#include "amhmvs_mapping/KeyframePoses.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/ros/image_rectifier.h"
#include "amhmvs_mapping/ros/mapping_config.h"
#include "amhmvs_mapping/ros/sequence_gaps.h"
#include "amhmvs_mapping/ros/tf_frame_filter.h"

namespace amhmvs_mapping {

// Counters of the inputs (typed; listed in diagnostics by inputStatFields()).
struct InputStats {
  uint64_t frames_received = 0;
  uint64_t ignored_while_paused = 0;
  uint64_t frames_not_keyframes = 0;  // too close to the last keyframe
  uint64_t frames_refused_pure_rotation = 0;  // turned enough but hardly moved: no baseline
  uint64_t frames_refused_blurred = 0;        // blurrier than the recent candidates
  uint64_t blurred_frames_taken_anyway = 0;   // after ~max_blurred_in_a_row refusals
  uint64_t keyframes_sent = 0;        // handed to the pipeline
  uint64_t dropped_encoding = 0;
  uint64_t dropped_bad_pose = 0;
  uint64_t dropped_bad_camera_info = 0;
  uint64_t dropped_bad_keyframe = 0;  // image and camera_info do not fit together, bad distortion
  uint64_t dropped_stamp_backwards = 0;
  uint64_t dropped_bad_stamp = 0;  // zero (header not filled) or more than a day ahead of the clock
  uint64_t dropped_missing_tf = 0;
  uint64_t dropped_bad_pose_update = 0;
  // Messages of an input topic that its publisher numbered (header.seq) but
  // that never reached our callback: the subscriber queue (sync_queue_size)
  // overflowed while the callbacks waited for the CPU, or the connection lost them.
  uint64_t dropped_before_subscriber = 0;
  uint64_t clock_jumps_back = 0;  // the ROS clock went back (a bag played again): stamps start again

  uint64_t droppedTotal() const {
    return dropped_encoding + dropped_bad_pose + dropped_bad_camera_info + dropped_bad_keyframe +
           dropped_stamp_backwards + dropped_bad_stamp + dropped_missing_tf + dropped_bad_pose_update +
           dropped_before_subscriber;
  }
};

struct InputStatField {
  const char* name;  // diagnostics key
  uint64_t InputStats::*value;
};
const std::vector<InputStatField>& inputStatFields();

class MappingInputs {
 public:
  struct Callbacks {
    std::function<void(amhmvs::Keyframe keyframe, const std_msgs::Header& header)> keyframe;
    std::function<void(int64_t id, const Eigen::Isometry3d& camera_to_world)> pose_update;
    // A frame the picker did not take, converted as a keyframe is (only with
    // depth_filter/enabled: it refines the newest keyframes' depth).
    std::function<void(amhmvs::Keyframe frame)> frame;
  };

  // Subscribes (in `nh`, transport hints from `pnh`).
  MappingInputs(ros::NodeHandle& nh, ros::NodeHandle& pnh, const MappingConfig& config, Callbacks callbacks);
  ~MappingInputs();  // unsubscribes first: no callback runs after it

  void setPaused(bool paused);
  // After ~reset: stamps may start again, the next frame is a keyframe.
  void restart();
  // New picking options (dynamic reconfigure); invalid ones are refused
  // (InputError) and the old ones stay.
  void setKeyframePicking(const amhmvs::KeyframePickerOptions& options);
  InputStats stats() const;
  // What is wrong with the input topics now, one line each (empty: nothing):
  // a topic without a publisher; a topic silent for `silence_s` seconds while
  // another input topic delivers; images and camera_info (and poses) that
  // arrive but never synchronise. Topics by their resolved names.
  std::vector<std::string> silenceProblems(double silence_s) const;
  // Every input topic delivered once and none for silence_s: the input ended
  // (a bag finished, the camera stopped); silenceProblems() then reports nothing.
  bool inputEnded(double silence_s) const;
  // Messages that reached each input topic's subscriber (before any
  // synchronisation), by resolved topic name, in subscription order.
  std::vector<std::pair<std::string, uint64_t>> messagesReceived() const;
  // Messages lost before each topic's subscriber: gaps in the publisher's
  // numbering (header.seq; roscpp and rospy publishers number every message,
  // rosbag play included). A numbering that goes back (a new publisher) starts
  // again; one publisher per topic is assumed. Same order as messagesReceived().
  std::vector<std::pair<std::string, uint64_t>> messagesLost() const;
  // Images that reached the subscriber but became no frame (pose, odometry
  // and tf modes): never matched by the synchroniser (or still held by it),
  // or dropped waiting for their transform (counted under missing_tf too).
  uint64_t imagesNotSynchronised() const;

 private:
  using PoseSync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                                   geometry_msgs::PoseStamped>;
  using OdometrySync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                                       nav_msgs::Odometry>;
  using CameraSync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo>;

  // One frame on its way to becoming a keyframe.
  struct Frame {
    int64_t id = 0;
    std_msgs::Header header;  // keyframe stamp and optical frame
    sensor_msgs::ImageConstPtr image;
    sensor_msgs::CameraInfoConstPtr info;
    Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
    double min_depth = 0, max_depth = 0;  // 0 = unknown (keyframe mode)
    std::vector<Eigen::Vector3d> sparse_points;  // world frame (keyframe mode)
  };

  void keyframeCallback(const amhmvs_mapping::KeyframeConstPtr& msg);
  void keyframePosesCallback(const amhmvs_mapping::KeyframePosesConstPtr& msg);
  void poseCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                    const geometry_msgs::PoseStampedConstPtr& pose);
  void odometryCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                        const nav_msgs::OdometryConstPtr& odometry);
  void cameraCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info);
  // A synchronised image + camera_info with its pose (given in pose_frame).
  void offerImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                  const std::string& pose_frame, const geometry_msgs::Pose& pose);
  // Checks a frame, picks keyframes when `pick`, converts and delivers it.
  void offer(Frame frame, const geometry_msgs::Pose& pose, bool pick);
  // The frame's image and camera (downscaled to ~max_image_size) as a core
  // keyframe; throws amhmvs::InputError when they do not fit together.
  // `converted`: the image already converted (imageFromMsg), else empty.
  amhmvs::Keyframe toKeyframe(const Frame& frame, amhmvs::ImageU8 converted) const;
  // A frame that is no keyframe, to callbacks_.frame (depth_filter/enabled).
  void offerBetweenKeyframes(const Frame& frame, amhmvs::ImageU8 converted);
  // One input topic: its resolved name, publishers and last arrival.
  struct Topic {
    std::string name;
    std::function<uint32_t()> publishers;
    ros::WallTime last_arrival;  // zero: never
    uint64_t messages = 0;       // arrivals so far
    SequenceGaps gaps;           // messages lost before the subscriber
  };
  // Registers a topic (constructor); returns its index for noteArrival().
  size_t watch(const std::string& name, std::function<uint32_t()> publishers);
  void noteArrival(size_t topic, uint32_t seq);
  // watch() for a subscriber filter, its arrivals noted before synchronisation.
  template <class Filter>
  size_t watchFilter(Filter& filter) {
    const size_t topic = watch(filter.getTopic(), [&filter] { return filter.getSubscriber().getNumPublishers(); });
    filter.registerCallback(boost::function<void(const typename Filter::MConstPtr&)>(
        [this, topic](const typename Filter::MConstPtr& message) { noteArrival(topic, message->header.seq); }));
    return topic;
  }
  void noteSynchronised();  // a synchronised frame (or a keyframe message) came
  void count(uint64_t InputStats::*counter);
  // Counts a dropped input and reports it (throttled per reason).
  void drop(uint64_t InputStats::*counter, const std::string& detail, uint64_t count = 1);

  bool endedLocked(double silence_s) const;  // stats_mutex_ held
  MappingConfig config_;
  Callbacks callbacks_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  ros::Subscriber keyframe_sub_, keyframe_poses_sub_;
  std::unique_ptr<image_transport::SubscriberFilter> image_filter_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::CameraInfo>> info_filter_;
  std::unique_ptr<message_filters::Subscriber<geometry_msgs::PoseStamped>> pose_filter_;
  std::unique_ptr<message_filters::Subscriber<nav_msgs::Odometry>> odometry_filter_;
  std::unique_ptr<message_filters::Synchronizer<PoseSync>> pose_sync_;
  std::unique_ptr<message_filters::Synchronizer<OdometrySync>> odometry_sync_;
  std::unique_ptr<message_filters::Synchronizer<CameraSync>> camera_sync_;
  std::unique_ptr<TfFrameFilter> tf_frames_;
  mutable ImageRectifier rectifier_;

  // Picking and stamp order (subscriber threads).
  std::mutex input_mutex_;
  bool paused_ = false;
  ros::Time last_stamp_;
  ros::Time last_clock_;  // ros::Time::now() at the last frame (a clock that goes back restarts the stamps)
  bool clock_restarted_ = false;  // since the jump, no frame of the new time yet
  amhmvs::KeyframePicker picker_;
  int64_t next_id_ = 0;

  mutable std::mutex stats_mutex_;
  InputStats stats_;
  std::vector<Topic> topics_;     // by stats_mutex_ (arrivals)
  size_t frame_topic_ = 0;        // the image topic, or the keyframe topic in keyframe mode
  ros::WallTime started_, last_synchronised_;
  std::map<std::string, ros::WallTime> last_report_;  // drop reason -> last report
};

}  // namespace amhmvs_mapping
