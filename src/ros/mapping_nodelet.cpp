#include "amhmvs_mapping/ros/mapping_nodelet.h"

#include <algorithm>
#include <cmath>

#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>
#include <tf2/exceptions.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/fallback_estimator.h"
#include "amhmvs_mapping/mapping/map_export.h"
#include "amhmvs_mapping/mapping/undistortion.h"
#include "amhmvs_mapping/mvs/problem_builder.h"
#include "amhmvs_mapping/ros/keyframe_markers.h"
#include "amhmvs_mapping/ros/mapping_tunables.h"
#include "amhmvs_mapping/ros/ros_conversions.h"

namespace amhmvs_mapping {

namespace {
constexpr double kReportPeriod = 5.0;  // seconds between reports of one drop reason
// Frusta drawn to this fraction of the scene depth: visible, not cluttering.
constexpr double kFrustumDepthFraction = 0.15;
// GPU failures in a row before every keyframe goes to the CPU.
constexpr int kSwitchToCpuAfter = 3;
}

MappingNodelet::~MappingNodelet() {
  // Inputs first, so that no callback feeds a stopping worker.
  pose_sync_.reset();
  odometry_sync_.reset();
  camera_sync_.reset();
  odometry_filter_.reset();
  image_filter_.reset();
  info_filter_.reset();
  pose_filter_.reset();
  keyframe_sub_.shutdown();
  keyframe_poses_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void MappingNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  std::string errors;
  config_ = loadMappingConfig(pnh, &errors);
  if (!errors.empty()) NODELET_ERROR("invalid parameters, defaults used instead:\n%s", errors.c_str());

  // Outputs.
  it_.reset(new image_transport::ImageTransport(nh));
  depth_pub_ = it_->advertiseCamera("depth/image", 5);
  confidence_pub_ = it_->advertise("confidence/image", 5);
  preview_pub_ = it_->advertise("depth/preview", 5);
  cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("keyframe_cloud", 5);
  // Latched: a late subscriber (rviz) gets the last map at once, and its
  // connection asks the worker for a current one (no export without subscribers).
  map_pub_ = nh.advertise<sensor_msgs::PointCloud2>(
      "map", 1,
      [this](const ros::SingleSubscriberPublisher&) {
        {
          std::lock_guard<std::mutex> lock(queue_mutex_);
          map_requested_ = true;
        }
        queue_cv_.notify_one();
      },
      ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("keyframe_markers", 5);

  // Services.
  save_map_srv_ = pnh.advertiseService("save_map", &MappingNodelet::saveMapService, this);
  reset_srv_ = pnh.advertiseService("reset", &MappingNodelet::resetService, this);
  pause_srv_ = pnh.advertiseService("pause", &MappingNodelet::pauseService, this);
  resume_srv_ = pnh.advertiseService("resume", &MappingNodelet::resumeService, this);

  // Diagnostics.
  diagnostics_.reset(new diagnostic_updater::Updater(nh, pnh, getName()));
  diagnostics_->setHardwareID("amhmvs_mapping");
  diagnostics_->add("depth estimation", this, &MappingNodelet::diagnose);
  // Wall timer: simulated time stops when a bag ends, the worker may not.
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(config_.diagnostics_period),
                                          [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });

  // Runtime tunables, starting from the loaded parameters.
  reconfigured_ = config_;
  reconfigure_server_.reset(new dynamic_reconfigure::Server<MappingTunablesConfig>(reconfigure_mutex_, pnh));
  MappingTunablesConfig initial = tunablesFrom(config_);
  reconfigure_server_->updateConfig(initial);
  reconfigure_server_->setCallback(
      [this](MappingTunablesConfig& tunables, uint32_t level) { reconfigure(tunables, level); });

  // Worker (creates the estimator: choosing the backend may take a while).
  worker_ = std::thread(&MappingNodelet::workerLoop, this);

  // Inputs.
  keyframe_poses_sub_ = nh.subscribe("keyframe_poses", 10, &MappingNodelet::keyframePosesCallback, this);
  if (config_.input_mode == "keyframe") {
    keyframe_sub_ = nh.subscribe("keyframe", 10, &MappingNodelet::keyframeCallback, this);
  } else {
    const uint32_t q = config_.sync_queue_size;
    image_filter_.reset(new image_transport::SubscriberFilter(
        *it_, "image", q, image_transport::TransportHints("raw", ros::TransportHints(), pnh)));
    info_filter_.reset(new message_filters::Subscriber<sensor_msgs::CameraInfo>(nh, "camera_info", q));
    if (config_.input_mode == "pose") {
      pose_filter_.reset(new message_filters::Subscriber<geometry_msgs::PoseStamped>(nh, "pose", q));
      PoseSync policy(q);
      policy.setMaxIntervalDuration(ros::Duration(config_.sync_max_interval));
      pose_sync_.reset(new message_filters::Synchronizer<PoseSync>(static_cast<const PoseSync&>(policy), *image_filter_, *info_filter_, *pose_filter_));
      pose_sync_->registerCallback(&MappingNodelet::poseCallback, this);
    } else if (config_.input_mode == "odometry") {
      odometry_filter_.reset(new message_filters::Subscriber<nav_msgs::Odometry>(nh, "odom", q));
      OdometrySync policy(q);
      policy.setMaxIntervalDuration(ros::Duration(config_.sync_max_interval));
      odometry_sync_.reset(new message_filters::Synchronizer<OdometrySync>(
          static_cast<const OdometrySync&>(policy), *image_filter_, *info_filter_, *odometry_filter_));
      odometry_sync_->registerCallback(&MappingNodelet::odometryCallback, this);
    } else {
      tf_buffer_.reset(new tf2_ros::Buffer());
      tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_, nh));
      CameraSync policy(q);
      policy.setMaxIntervalDuration(ros::Duration(config_.sync_max_interval));
      camera_sync_.reset(new message_filters::Synchronizer<CameraSync>(static_cast<const CameraSync&>(policy), *image_filter_, *info_filter_));
      camera_sync_->registerCallback(&MappingNodelet::cameraCallback, this);
    }
  }
  NODELET_INFO("amhmvs mapping: input mode %s, queue %d, up to %d sources, default depth %.2f..%.2f m, "
               "max image size %d, voxel size %.3f m",
               config_.input_mode.c_str(), config_.queue_size, config_.mapper.sources.max_sources,
               config_.mapper.depth_range.default_min, config_.mapper.depth_range.default_max,
               config_.max_image_size, config_.mapper.map.leaf_size);
}

// ---------------------------------------------------------------- inputs ---

void MappingNodelet::keyframeCallback(const amhmvs_mapping::KeyframeConstPtr& msg) {
  Frame frame;
  frame.id = msg->keyframe_id;
  frame.stamp = msg->header.stamp;
  frame.optical_frame = !msg->image.header.frame_id.empty() ? msg->image.header.frame_id
                                                            : msg->camera_info.header.frame_id;
  // Aliasing pointers: share ownership of the keyframe message, no copy.
  frame.image = sensor_msgs::ImageConstPtr(msg, &msg->image);
  frame.info = sensor_msgs::CameraInfoConstPtr(msg, &msg->camera_info);
  frame.min_depth = msg->min_depth;
  frame.max_depth = msg->max_depth;
  for (const geometry_msgs::Point& p : msg->sparse_points) frame.sparse_points.emplace_back(p.x, p.y, p.z);
  offer(std::move(frame), msg->camera_to_world, false);
}

void MappingNodelet::keyframePosesCallback(const amhmvs_mapping::KeyframePosesConstPtr& msg) {
  std::map<int64_t, Eigen::Isometry3d> updates;
  for (const amhmvs_mapping::KeyframePose& entry : msg->poses) {
    Eigen::Isometry3d pose;
    const std::string problem = poseFromMsg(entry.camera_to_world, &pose);
    if (!problem.empty()) {
      drop("bad_pose_update", "keyframe " + std::to_string(entry.keyframe_id) + ": " + problem);
      continue;
    }
    updates[entry.keyframe_id] = pose;
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    for (const auto& update : updates) pose_updates_[update.first] = update.second;
  }
  queue_cv_.notify_one();
}

void MappingNodelet::poseCallback(const sensor_msgs::ImageConstPtr& image,
                                  const sensor_msgs::CameraInfoConstPtr& info,
                                  const geometry_msgs::PoseStampedConstPtr& pose) {
  offerImage(image, info, pose->header.frame_id, pose->pose);
}

void MappingNodelet::odometryCallback(const sensor_msgs::ImageConstPtr& image,
                                      const sensor_msgs::CameraInfoConstPtr& info,
                                      const nav_msgs::OdometryConstPtr& odometry) {
  offerImage(image, info, odometry->header.frame_id, odometry->pose.pose);
}

void MappingNodelet::offerImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                                const std::string& pose_frame, const geometry_msgs::Pose& pose) {
  if (!pose_frame.empty() && pose_frame != config_.fixed_frame) {
    NODELET_WARN_ONCE("%s frame '%s' is not ~fixed_frame '%s': the poses are used as they are",
                      config_.input_mode.c_str(), pose_frame.c_str(), config_.fixed_frame.c_str());
  }
  Frame frame;
  frame.stamp = image->header.stamp;
  frame.optical_frame = image->header.frame_id;
  frame.image = image;
  frame.info = info;
  offer(std::move(frame), pose, true);
}

void MappingNodelet::cameraCallback(const sensor_msgs::ImageConstPtr& image,
                                    const sensor_msgs::CameraInfoConstPtr& info) {
  // Polls with a wall-clock timeout: tf2's own timeout runs on ROS time,
  // which stands still when a replayed bag ends (the callback would hang).
  const std::string& source = image->header.frame_id;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(config_.tf_timeout);
  std::string error;
  while (!tf_buffer_->canTransform(config_.fixed_frame, source, image->header.stamp, &error)) {
    if (ros::WallTime::now() >= deadline || !ros::ok()) {
      drop("missing_tf", "no transform " + config_.fixed_frame + " <- " + source + " within " +
                             std::to_string(config_.tf_timeout) + " s: " + error);
      return;
    }
    error.clear();
    ros::WallDuration(0.005).sleep();
  }
  geometry_msgs::TransformStamped transform;
  try {
    transform = tf_buffer_->lookupTransform(config_.fixed_frame, source, image->header.stamp);
  } catch (const tf2::TransformException& e) {
    drop("missing_tf", e.what());
    return;
  }
  geometry_msgs::Pose pose;
  pose.position.x = transform.transform.translation.x;
  pose.position.y = transform.transform.translation.y;
  pose.position.z = transform.transform.translation.z;
  pose.orientation = transform.transform.rotation;
  offerImage(image, info, config_.fixed_frame, pose);
}

void MappingNodelet::offer(Frame frame, const geometry_msgs::Pose& pose, bool pick) {
  count("frames_received");
  if (paused_) {
    count("ignored_while_paused");
    return;
  }
  if (!supportedEncoding(frame.image->encoding)) {
    drop("encoding", "image encoding '" + frame.image->encoding + "' is not mono8, rgb8 or bgr8");
    return;
  }
  std::string problem = poseFromMsg(pose, &frame.camera_to_world);
  if (!problem.empty()) {
    drop("bad_pose", problem);
    return;
  }
  amhmvs::PinholeCamera camera;
  problem = cameraFromMsg(*frame.info, frame.image->width, frame.image->height, frame.camera_to_world, &camera);
  if (!problem.empty()) {
    drop("bad_camera_info", problem);
    return;
  }
  std::lock_guard<std::mutex> lock(input_mutex_);
  if (!last_stamp_.isZero() && frame.stamp < last_stamp_) {
    std::ostringstream out;
    out << "stamp " << frame.stamp << " is before the previous input's " << last_stamp_
        << " (call ~reset after a time jump)";
    drop("stamp_backwards", out.str());
    return;
  }
  last_stamp_ = frame.stamp;
  if (pick) {
    if (have_last_keyframe_) {
      const double moved = (frame.camera_to_world.translation() - last_keyframe_pose_.translation()).norm();
      const double turned = Eigen::AngleAxisd(last_keyframe_pose_.linear().transpose() *
                                              frame.camera_to_world.linear()).angle() * 180.0 / M_PI;
      if (moved < config_.keyframe_min_translation && turned < config_.keyframe_min_rotation_deg) {
        count("frames_not_keyframes");
        return;
      }
    }
    frame.id = next_id_++;
  }
  have_last_keyframe_ = true;
  last_keyframe_pose_ = frame.camera_to_world;
  enqueue(std::move(frame));
  count("keyframes_received");  // after enqueue: with this count, idle is false
}

void MappingNodelet::enqueue(Frame frame) {
  size_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stop_) return;
    worker_idle_ = false;
    while (queue_.size() >= static_cast<size_t>(config_.queue_size)) {
      queue_.pop_front();
      ++dropped;
    }
    queue_.push_back(std::move(frame));
  }
  queue_cv_.notify_one();
  if (dropped > 0) {
    uint64_t total;
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      total = drops_["queue_full"] += dropped;
    }
    NODELET_WARN_THROTTLE(kReportPeriod,
                          "input queue full (%d keyframes): dropped the oldest; %lu dropped so far "
                          "(estimation is slower than the keyframe rate)",
                          config_.queue_size, static_cast<unsigned long>(total));
  }
}

void MappingNodelet::drop(const std::string& reason, const std::string& detail) {
  uint64_t total;
  bool report;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    total = ++drops_[reason];
    const ros::WallTime now = ros::WallTime::now();
    ros::WallTime& last = last_report_[reason];
    report = last.isZero() || (now - last).toSec() >= kReportPeriod;
    if (report) last = now;
  }
  if (report)
    NODELET_ERROR("dropped input (%s): %s [%lu dropped for this reason]", reason.c_str(), detail.c_str(),
                  static_cast<unsigned long>(total));
}

void MappingNodelet::count(const std::string& what) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++counts_[what];
}

// ---------------------------------------------------------------- worker ---

void MappingNodelet::workerLoop() {
  amhmvs::Backend backend = amhmvs::parseBackend(config_.backend);
  if (backend == amhmvs::Backend::kAuto) {
    std::string description;
    if (amhmvs::cudaBackendAvailable(&description)) {
      backend = amhmvs::Backend::kCuda;
    } else {
      NODELET_WARN("CUDA backend not usable (%s): depth estimation runs on the CPU backend, which is slow; "
                   "set ~max_image_size (e.g. 256..512) for online rates",
                   description.c_str());
      backend = amhmvs::Backend::kCpu;
    }
  }
  try {
    estimator_.reset(new amhmvs::DepthEstimator(config_.estimator, backend));
  } catch (const std::exception& e) {
    NODELET_ERROR("backend %s failed (%s): using the CPU backend", amhmvs::backendName(backend), e.what());
    estimator_.reset(new amhmvs::DepthEstimator(config_.estimator, amhmvs::Backend::kCpu));
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    backend_name_ = amhmvs::backendName(estimator_->backend());
  }
  NODELET_INFO("depth estimation backend: %s", amhmvs::backendName(estimator_->backend()));
  // GPU failures: the keyframe reruns on the CPU; after kSwitchToCpuAfter
  // failures in a row every keyframe does. The CPU has no fallback.
  amhmvs::EstimateFunction cpu;
  if (estimator_->backend() != amhmvs::Backend::kCpu) {
    cpu = [this](const amhmvs::DepthProblem& problem) {
      if (!cpu_estimator_) cpu_estimator_.reset(new amhmvs::DepthEstimator(config_.estimator, amhmvs::Backend::kCpu));
      return cpu_estimator_->estimate(problem);
    };
  }
  auto fallback = std::make_shared<amhmvs::FallbackEstimator>(
      [this](const amhmvs::DepthProblem& problem) { return estimator_->estimate(problem); }, cpu,
      kSwitchToCpuAfter, [this](const std::string& line) {
        NODELET_ERROR_THROTTLE(kReportPeriod, "%s backend: %s", amhmvs::backendName(estimator_->backend()),
                               line.c_str());
        count("cpu_fallbacks");
      });
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    mapper_.reset(new amhmvs::OnlineMapper(config_.mapper, [this, fallback](const amhmvs::DepthProblem& problem) {
      amhmvs::DepthMap map = (*fallback)(problem);
      if (fallback->switched()) {
        std::lock_guard<std::mutex> stats(stats_mutex_);
        backend_name_ = std::string(amhmvs::backendName(estimator_->backend())) + " failed, now cpu";
      }
      return map;
    }));
  }

  const std::chrono::duration<double> map_period(config_.map_publish_period);
  std::map<int64_t, Eigen::Isometry3d> updates;
  std::unique_ptr<MappingConfig> next_config;
  while (true) {
    bool map_wanted = false;  // a subscriber connected to ~map
    Frame frame;
    bool have_frame = false;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      // Wakes at the map rate at the latest, to republish it; at once while
      // late work (late depth maps, refinements) may remain.
      queue_cv_.wait_for(lock, worker_idle_ ? map_period : std::chrono::duration<double>(0), [this] {
        return stop_ || !queue_.empty() || !pose_updates_.empty() || pending_config_ || map_requested_;
      });
      if (stop_) break;
      map_wanted = map_requested_;
      map_requested_ = false;
      next_config.swap(pending_config_);
      updates.swap(pose_updates_);
      if (!queue_.empty()) {
        frame = std::move(queue_.front());
        queue_.pop_front();
        have_frame = true;
      }
    }
    if (next_config) applyReconfiguration(*next_config);
    next_config.reset();
    if (reset_requested_.exchange(false)) {
      std::lock_guard<std::mutex> lock(mapper_mutex_);
      mapper_->reset();
      keyframe_headers_.clear();
    }
    if (!updates.empty()) applyPoseUpdates(std::move(updates));
    updates.clear();
    if (have_frame) {
      try {
        process(frame);
      } catch (const std::exception& e) {
        drop("processing_error", "keyframe " + std::to_string(frame.id) + ": " + e.what());
      }
    }
    // At most one late depth map per pass, refinements only when no keyframe
    // waits: new keyframes keep their rate.
    bool did_late_work = estimateLate();
    if (!did_late_work && queueEmpty()) did_late_work = refine();
    // Idle: nothing was left to do in this pass (for monitors and tests:
    // every output of the input so far is out).
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);  // enqueue() clears it under this lock
      worker_idle_ = !have_frame && !did_late_work && queue_.empty();
    }
    const bool due = (ros::WallTime::now() - last_map_publish_).toSec() >= config_.map_publish_period;
    publishMap(due || map_wanted);
  }
}

amhmvs::Keyframe MappingNodelet::toKeyframe(const Frame& frame) const {
  amhmvs::Keyframe keyframe;
  keyframe.id = frame.id;
  keyframe.stamp = frame.stamp.toSec();
  std::string problem = imageFromMsg(*frame.image, &keyframe.image);
  if (problem.empty())
    problem = cameraFromMsg(*frame.info, keyframe.image.width, keyframe.image.height, frame.camera_to_world,
                            &keyframe.camera);
  amhmvs::Distortion distortion;
  if (problem.empty()) problem = amhmvs::parseDistortion(frame.info->distortion_model, frame.info->D, &distortion);
  if (!problem.empty()) throw amhmvs::InputError(problem);
  // Undistorted to the pinhole with the same K (what depth/camera_info says).
  if (!distortion.isZero()) keyframe.image = amhmvs::undistortImage(keyframe.image, keyframe.camera, distortion);
  // Downscaled as the offline tools do (ProblemOptions::max_image_size).
  amhmvs::ProblemOptions size_options;
  size_options.max_image_size = config_.max_image_size;
  int width = 0, height = 0;
  amhmvs::scaledSize(keyframe.image.width, keyframe.image.height, size_options, &width, &height);
  if (width != keyframe.image.width || height != keyframe.image.height) {
    keyframe.image = amhmvs::resizeArea(keyframe.image, width, height);
    keyframe.camera = keyframe.camera.resized(width, height);
  }
  const bool msg_range = frame.min_depth > 0 && frame.max_depth > frame.min_depth && std::isfinite(frame.max_depth);
  if (msg_range) {
    keyframe.depth_min = frame.min_depth;
    keyframe.depth_max = frame.max_depth;
  }
  keyframe.sparse_points = frame.sparse_points;
  return keyframe;
}

void MappingNodelet::process(const Frame& frame) {
  amhmvs::Keyframe keyframe;
  try {
    keyframe = toKeyframe(frame);
  } catch (const amhmvs::InputError& e) {
    drop("bad_keyframe", "keyframe " + std::to_string(frame.id) + ": " + e.what());
    return;
  }
  amhmvs::KeyframeResult result;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    try {
      result = mapper_->process(std::move(keyframe));
    } catch (const amhmvs::InputError& e) {
      drop("invalid_keyframe", "keyframe " + std::to_string(frame.id) + ": " + e.what());
      return;
    } catch (const amhmvs::BackendError& e) {
      drop("backend_error", "keyframe " + std::to_string(frame.id) + ": " + e.what());
      return;
    }
  }
  std_msgs::Header header;
  header.stamp = frame.stamp;
  header.frame_id = frame.optical_frame;
  handleResult(result, header);
}

bool MappingNodelet::estimateLate() {
  return lateWork("late", [this](amhmvs::KeyframeResult* result) { return mapper_->estimateLate(result); });
}

bool MappingNodelet::refine() {
  return lateWork("refinement", [this](amhmvs::KeyframeResult* result) { return mapper_->refine(result); });
}

bool MappingNodelet::queueEmpty() {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return queue_.empty();
}

bool MappingNodelet::lateWork(const char* what,
                              const std::function<bool(amhmvs::KeyframeResult*)>& step) {
  amhmvs::KeyframeResult result;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    try {
      if (!step(&result)) return false;
    } catch (const std::exception& e) {
      // A late keyframe stays a source only; a refined one keeps its depth map.
      drop(std::string(what) + "_estimate_failed", "keyframe " + std::to_string(result.id) + ": " + e.what());
      return true;
    }
  }
  const auto stored = keyframe_headers_.find(result.id);
  if (stored == keyframe_headers_.end()) return true;  // cannot happen: every stored keyframe has one
  NODELET_INFO("keyframe %ld: %s depth map from %zu source views (best: keyframe %ld)", static_cast<long>(result.id),
               what, result.selection.source_ids.size(), static_cast<long>(result.selection.source_ids.front()));
  if (result.late)
    count("late_depth_maps");
  else
    count("refined_depth_maps");
  handleResult(result, stored->second);
  return true;
}

void MappingNodelet::handleResult(const amhmvs::KeyframeResult& result, const std_msgs::Header& header) {
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    std::lock_guard<std::mutex> stats(stats_mutex_);
    counts_["stored_keyframes"] = mapper_->store().size();
    counts_["keyframes_evicted"] = mapper_->store().evictedCount();
    counts_["keyframes_waiting_for_fusion"] = mapper_->waitingForFusion().size();
    counts_["keyframes_evicted_before_fusion"] = mapper_->evictedBeforeFusion();
    counts_["keyframes_waiting_for_sources"] = mapper_->waitingForSources().size();
    counts_["keyframes_evicted_without_depth"] = mapper_->evictedWithoutDepth();
  }
  if (!result.late && !result.refined) keyframe_headers_[result.id] = header;
  for (int64_t id : result.evicted) {
    keyframe_headers_.erase(id);
    const bool unfused = std::count(result.evicted_before_fusion.begin(), result.evicted_before_fusion.end(), id);
    if (unfused) NODELET_WARN("keyframe %ld: evicted from the store before it could be fused (never in the map)",
                              static_cast<long>(id));
  }
  if (!result.has_depth) {
    count("keyframes_without_sources");
    NODELET_INFO("keyframe %ld: no source view yet (%s): stored as a source; its depth map follows once later "
                 "keyframes qualify as its sources",
                 static_cast<long>(result.id), result.selection.reason.c_str());
  } else {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (!result.refined) ++counts_["depth_maps"];
    last_estimate_ms_ = result.depth.milliseconds;
    last_gpu_memory_bytes_ = result.depth.gpu_memory_bytes;
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.emplace("keyframes_fused", 0);  // reported from the first keyframe on, 0 included
    for (const amhmvs::FusedKeyframe& fused : result.fused) {
      ++counts_[fused.again ? "keyframes_fused_again" : "keyframes_fused"];
      counts_["map_points_added"] += fused.map_update.added_points;
      counts_["map_points_skipped_invalid"] += fused.map_update.skipped_invalid;
      counts_["map_points_over_budget"] += fused.map_update.dropped_over_budget;
      counts_["map_points_outside_region"] += fused.map_update.outside_region;
    }
  }
  NODELET_DEBUG("keyframe %ld%s: %zu sources, depth %.2f..%.2f m (%s), %.0f ms, %s; %zu keyframes fused, %zu wait",
                static_cast<long>(result.id), result.late ? " (late)" : result.refined ? " (refined)" : "",
                result.selection.source_ids.size(),
                result.depth_range.min, result.depth_range.max,
                amhmvs::depthRangeSourceName(result.depth_range.source), result.depth.milliseconds,
                result.fused_now ? "fused" : "waits for fusion", result.fused.size(), result.waiting_for_fusion);
  publishKeyframe(result, header);
}

void MappingNodelet::publishKeyframe(const amhmvs::KeyframeResult& result, const std_msgs::Header& header) {
  if (markers_pub_.getNumSubscribers() > 0) {
    std::vector<MarkerCamera> cameras;
    {
      std::lock_guard<std::mutex> lock(mapper_mutex_);
      for (int64_t id : mapper_->store().ids()) cameras.push_back({id, mapper_->store().keyframe(id).camera});
    }
    std_msgs::Header fixed;
    fixed.stamp = header.stamp;
    fixed.frame_id = config_.fixed_frame;
    const double frustum_depth = kFrustumDepthFraction * result.selection.scene_depth.depth;
    markers_pub_.publish(keyframeMarkers(cameras, result.id, result.selection.source_ids, frustum_depth, fixed));
  }
  if (!result.has_depth) return;
  // Expensive outputs only for subscribers.
  if (depth_pub_.getNumSubscribers() > 0)
    depth_pub_.publish(depthImageMsg(result.depth.depth, header), cameraInfoMsg(result.camera, header));
  if (confidence_pub_.getNumSubscribers() > 0) confidence_pub_.publish(confidenceImageMsg(result.depth, header));
  if (preview_pub_.getNumSubscribers() > 0) {
    sensor_msgs::ImagePtr preview = depthPreviewMsg(result.depth.depth, header);
    if (preview) preview_pub_.publish(preview);
  }
  // keyframe_cloud: when a keyframe is fused (this one, earlier ones that
  // waited for enough consistency views, or a refined one again), with that
  // keyframe's header.
  for (const amhmvs::FusedKeyframe& fused : result.fused) {
    const auto stored = keyframe_headers_.find(fused.id);
    const std_msgs::Header& fused_header = stored != keyframe_headers_.end() ? stored->second : header;
    if (cloud_pub_.getNumSubscribers() > 0) cloud_pub_.publish(cloudMsg(keyframeCloud(fused.points), fused_header));
  }
}

void MappingNodelet::publishMap(bool republish) {
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    std::lock_guard<std::mutex> stats(stats_mutex_);
    map_voxels_ = mapper_->map().voxelCount();  // re-posing and reset change it too
  }
  // Nobody listens: no export. A new subscriber's connection asks for one.
  if (map_pub_.getNumSubscribers() == 0) return;
  sensor_msgs::PointCloud2Ptr msg;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    const bool changed = mapper_->mapRevision() != published_map_revision_;
    if (!changed && !republish) return;
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = config_.fixed_frame;
    msg = cloudMsg(mapper_->map().exportCloud(), header);
    published_map_revision_ = mapper_->mapRevision();
  }
  last_map_publish_ = ros::WallTime::now();
  map_pub_.publish(msg);
  count("map_publications");
}

void MappingNodelet::applyPoseUpdates(std::map<int64_t, Eigen::Isometry3d> updates) {
  uint64_t applied = 0, not_stored = 0;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    for (const auto& update : updates) {
      try {
        if (mapper_->updatePose(update.first, update.second))
          ++applied;
        else
          ++not_stored;  // evicted, reset, or not yet processed
      } catch (const amhmvs::InputError& e) {
        drop("bad_pose_update", e.what());
      }
    }
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_["pose_updates_applied"] += applied;
  if (not_stored > 0) counts_["pose_updates_not_stored"] += not_stored;
}

bool MappingNodelet::saveMapService(amhmvs_mapping::SaveMap::Request& req, amhmvs_mapping::SaveMap::Response& res) {
  try {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    if (!mapper_) throw amhmvs::InputError("the mapper is not started yet");
    amhmvs::writeMap(req.path, mapper_->map());
    res.success = true;
    res.message = "saved " + std::to_string(mapper_->map().voxelCount()) + " points to " + req.path;
    NODELET_INFO("%s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("save_map failed: ") + e.what();
    NODELET_ERROR("%s", res.message.c_str());
  }
  return true;
}

void MappingNodelet::applyReconfiguration(const MappingConfig& next) {
  try {
    const std::string problems = next.estimator.validate();
    if (!problems.empty()) throw amhmvs::InputError("estimator options:\n" + problems);
    {
      std::lock_guard<std::mutex> lock(mapper_mutex_);
      mapper_->setOptions(next.mapper);  // a new voxel size rebuilds the map
    }
    estimator_.reset(new amhmvs::DepthEstimator(next.estimator, estimator_->backend()));
    cpu_estimator_.reset();
    config_.estimator = next.estimator;
    config_.mapper = next.mapper;
    count("reconfigurations");
    NODELET_INFO("reconfigured: %d iterations, up to %d sources, voxel size %.3f m", next.estimator.num_iterations,
                 next.mapper.sources.max_sources, next.mapper.map.leaf_size);
  } catch (const std::exception& e) {
    drop("bad_reconfiguration", e.what());
  }
}

void MappingNodelet::reconfigure(MappingTunablesConfig& tunables, uint32_t /*level*/) {
  applyTunables(tunables, &reconfigured_);
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    config_.keyframe_min_translation = reconfigured_.keyframe_min_translation;
    config_.keyframe_min_rotation_deg = reconfigured_.keyframe_min_rotation_deg;
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    pending_config_.reset(new MappingConfig(reconfigured_));
  }
  queue_cv_.notify_one();
}

// -------------------------------------------------------------- services ---

bool MappingNodelet::resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  size_t cleared;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    cleared = queue_.size();
    queue_.clear();
  }
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    last_stamp_ = ros::Time();
    have_last_keyframe_ = false;
  }
  reset_requested_ = true;
  res.success = true;
  res.message = "reset: " + std::to_string(cleared) + " queued keyframes discarded, stored keyframes cleared";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

bool MappingNodelet::pauseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  paused_ = true;
  res.success = true;
  res.message = "paused: new input is ignored until ~resume";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

bool MappingNodelet::resumeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  paused_ = false;
  res.success = true;
  res.message = "resumed";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

void MappingNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  size_t queued;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queued = queue_.size();
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  uint64_t dropped = 0;
  for (const auto& entry : drops_) dropped += entry.second;
  if (dropped == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, paused_ ? "paused" : "ok");
  else
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu inputs dropped", static_cast<unsigned long>(dropped));
  status.add("backend", backend_name_);
  status.add("input mode", config_.input_mode);
  status.add("paused", static_cast<bool>(paused_));
  status.add("idle", static_cast<bool>(worker_idle_));
  status.add("queued", queued);
  status.add("last estimate ms", last_estimate_ms_);
  status.add("gpu memory MiB", last_gpu_memory_bytes_ / double(1 << 20));
  status.add("map voxels", map_voxels_);
  const ros::WallTime now = ros::WallTime::now();
  const uint64_t frames = counts_.count("frames_received") ? counts_.at("frames_received") : 0;
  if (!last_rate_time_.isZero() && now > last_rate_time_)
    status.add("input rate hz", (frames - last_rate_frames_) / (now - last_rate_time_).toSec());
  last_rate_time_ = now;
  last_rate_frames_ = frames;
  for (const auto& entry : counts_) status.add(entry.first, entry.second);
  for (const auto& entry : drops_) status.add("dropped: " + entry.first, entry.second);
}

}  // namespace amhmvs_mapping

PLUGINLIB_EXPORT_CLASS(amhmvs_mapping::MappingNodelet, nodelet::Nodelet)
