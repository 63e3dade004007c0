// amhmvs_mapping/MappingNodelet: online dense mapping of SLAM keyframes.
//
// Inputs (remappable, in the nodelet's namespace), by ~input_mode:
//   pose:     image (image_transport) + camera_info + pose (PoseStamped,
//             camera-to-world of the optical frame), approximate-time synced;
//   odometry: the same with odom (nav_msgs/Odometry) instead of pose;
//   tf:       image + camera_info, pose from tf2: fixed_frame <- image frame;
//   keyframe: keyframe (amhmvs_mapping/Keyframe).
// In pose, odometry and tf modes a frame becomes a keyframe when it moved at
// least ~keyframe_min_translation or turned at least ~keyframe_min_rotation_deg
// from the last keyframe.
// Outputs: depth/image (REP-118 32FC1) + depth/camera_info, confidence/image,
// depth/preview (bgr8), keyframe_cloud (fused points, optical frame), map
// (global map, fixed frame, latched), keyframe_markers (frusta, source
// links), /diagnostics.
// keyframe_poses (KeyframePoses): loop-closure pose updates; they re-pose the
// keyframes' points in the map.
// Services: ~save_map (SaveMap: .ply or .pcd), ~reset, ~pause, ~resume.
//
// The mapping itself is amhmvs::OnlineMapper (store, source selection, depth
// range, fusion, voxel map); this class only converts and wires. onInit only
// wires up; the mapper runs on a worker thread fed by a bounded drop-oldest
// queue. Bad input (encoding, pose, camera_info, stamps, tf) is dropped,
// counted and reported with throttled errors.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <nav_msgs/Odometry.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "amhmvs_mapping/Keyframe.h"
#include "amhmvs_mapping/KeyframePoses.h"
#include "amhmvs_mapping/MappingTunablesConfig.h"
#include "amhmvs_mapping/SaveMap.h"
#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/ros/mapping_config.h"

namespace amhmvs_mapping {

class MappingNodelet : public nodelet::Nodelet {
 public:
  MappingNodelet() = default;
  ~MappingNodelet() override;

 private:
  // One keyframe waiting for the worker.
  struct Frame {
    int64_t id = 0;
    ros::Time stamp;
    std::string optical_frame;
    sensor_msgs::ImageConstPtr image;
    sensor_msgs::CameraInfoConstPtr info;
    Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
    double min_depth = 0, max_depth = 0;  // 0 = unknown
    std::vector<Eigen::Vector3d> sparse_points;  // world frame (keyframe mode)
  };
  using PoseSync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                                   geometry_msgs::PoseStamped>;
  using OdometrySync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                                       nav_msgs::Odometry>;
  using CameraSync = message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo>;

  void onInit() override;

  // Input callbacks (subscriber threads).
  void keyframeCallback(const amhmvs_mapping::KeyframeConstPtr& msg);
  // Loop closure: new camera-to-world poses of stored keyframes.
  void keyframePosesCallback(const amhmvs_mapping::KeyframePosesConstPtr& msg);
  void poseCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                    const geometry_msgs::PoseStampedConstPtr& pose);
  void odometryCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                        const nav_msgs::OdometryConstPtr& odometry);
  void cameraCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info);
  // A synchronised image + camera_info with its pose (given in pose_frame).
  void offerImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                  const std::string& pose_frame, const geometry_msgs::Pose& pose);
  // Checks a frame (stamp order, encoding, camera_info, pose), picks keyframes
  // when `pick` and enqueues it.
  void offer(Frame frame, const geometry_msgs::Pose& pose, bool pick);
  void enqueue(Frame frame);
  // Counts a dropped input and reports it (throttled per reason).
  void drop(const std::string& reason, const std::string& detail);
  void count(const std::string& what);

  // Worker thread.
  void workerLoop();
  // The frame's image and camera (downscaled to ~max_image_size) as a core
  // keyframe; throws InputError when they do not fit together.
  amhmvs::Keyframe toKeyframe(const Frame& frame) const;
  void process(const Frame& frame);
  // Gives one keyframe that arrived without a source view its depth map once
  // later keyframes qualify (OnlineMapper::estimateLate); published with the
  // keyframe's own stamp and frame. False when there was nothing to do.
  bool estimateLate();
  // Re-estimates one keyframe whose sources improved (OnlineMapper::refine);
  // its depth image and cloud are published again with its stamp and frame.
  bool refine();
  // One step of late work under the mapper lock; counts, logs and publishes.
  bool lateWork(const char* what, const std::function<bool(amhmvs::KeyframeResult*)>& step);
  bool queueEmpty();
  // Counts, logs and publishes what the mapper did with a keyframe.
  void handleResult(const amhmvs::KeyframeResult& result, const std_msgs::Header& header);
  void publishKeyframe(const amhmvs::KeyframeResult& result, const std_msgs::Header& header);
  void applyPoseUpdates(std::map<int64_t, Eigen::Isometry3d> updates);
  // Publishes the global map, only while it has subscribers, when it changed
  // or `republish` (the rate, or a new subscriber).
  void publishMap(bool republish);

  bool saveMapService(amhmvs_mapping::SaveMap::Request& req, amhmvs_mapping::SaveMap::Response& res);
  bool resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool pauseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool resumeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  // dynamic_reconfigure: keyframe picking at once, the rest by the worker
  // before its next keyframe.
  void reconfigure(MappingTunablesConfig& tunables, uint32_t level);
  // Worker: applies a pending reconfiguration.
  void applyReconfiguration(const MappingConfig& next);

  MappingConfig config_;

  // Wiring.
  std::unique_ptr<image_transport::ImageTransport> it_;
  ros::Subscriber keyframe_sub_, keyframe_poses_sub_;
  std::unique_ptr<image_transport::SubscriberFilter> image_filter_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::CameraInfo>> info_filter_;
  std::unique_ptr<message_filters::Subscriber<geometry_msgs::PoseStamped>> pose_filter_;
  std::unique_ptr<message_filters::Synchronizer<PoseSync>> pose_sync_;
  std::unique_ptr<message_filters::Synchronizer<CameraSync>> camera_sync_;
  std::unique_ptr<message_filters::Subscriber<nav_msgs::Odometry>> odometry_filter_;
  std::unique_ptr<message_filters::Synchronizer<OdometrySync>> odometry_sync_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  image_transport::CameraPublisher depth_pub_;
  image_transport::Publisher confidence_pub_, preview_pub_;
  ros::Publisher cloud_pub_, map_pub_, markers_pub_;
  ros::ServiceServer save_map_srv_, reset_srv_, pause_srv_, resume_srv_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  boost::recursive_mutex reconfigure_mutex_;  // the type dynamic_reconfigure takes
  std::unique_ptr<dynamic_reconfigure::Server<MappingTunablesConfig>> reconfigure_server_;
  MappingConfig reconfigured_;  // the reconfigure callback's copy
  ros::WallTimer diagnostics_timer_;

  // Input state (subscriber threads), guarded by input_mutex_.
  std::mutex input_mutex_;
  ros::Time last_stamp_;
  bool have_last_keyframe_ = false;
  Eigen::Isometry3d last_keyframe_pose_ = Eigen::Isometry3d::Identity();
  int64_t next_id_ = 0;

  // Queue, guarded by queue_mutex_.
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Frame> queue_;
  std::map<int64_t, Eigen::Isometry3d> pose_updates_;  // keyframe id -> camera-to-world
  std::unique_ptr<MappingConfig> pending_config_;      // from reconfigure(), for the worker
  bool map_requested_ = false;                         // a subscriber connected to ~map
  bool stop_ = false;
  std::atomic<bool> paused_{false};
  // Worker: headers (stamp, optical frame) of the stored keyframes, for the
  // outputs that come after their turn (late and refined depth, fusion).
  std::map<int64_t, std_msgs::Header> keyframe_headers_;
  std::atomic<bool> reset_requested_{false};
  std::atomic<bool> worker_idle_{false};  // the last pass found nothing to do
  std::thread worker_;

  // Counters (any thread), guarded by stats_mutex_.
  std::mutex stats_mutex_;
  std::map<std::string, uint64_t> drops_;    // reason -> count
  std::map<std::string, uint64_t> counts_;   // event -> count
  std::map<std::string, ros::WallTime> last_report_;
  std::string backend_name_ = "not started";
  double last_estimate_ms_ = 0;
  size_t last_gpu_memory_bytes_ = 0;
  size_t map_voxels_ = 0;
  ros::WallTime last_rate_time_;
  uint64_t last_rate_frames_ = 0;

  // Worker state (worker thread; the mapper also by ~save_map, under mapper_mutex_).
  std::unique_ptr<amhmvs::DepthEstimator> estimator_, cpu_estimator_;
  std::mutex mapper_mutex_;
  std::unique_ptr<amhmvs::OnlineMapper> mapper_;
  uint64_t published_map_revision_ = 0;
  ros::WallTime last_map_publish_;
};

}  // namespace amhmvs_mapping
