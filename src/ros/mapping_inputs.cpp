#include "amhmvs_mapping/ros/mapping_inputs.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <nodelet/nodelet.h>
#include <tf2_eigen/tf2_eigen.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/problem_builder.h"
#include "amhmvs_mapping/ros/ros_conversions.h"

namespace amhmvs_mapping {
namespace {
constexpr double kReportPeriod = 5.0;  // seconds between reports of one drop reason
// A stamp this far ahead of the clock would make every later input "backwards".
constexpr double kMaxStampAheadSeconds = 86400;
}

const std::vector<InputStatField>& inputStatFields() {
  // Names are the diagnostics keys (README, rostests).
  static const std::vector<InputStatField> fields = {
      {"frames_received", &InputStats::frames_received},
      {"ignored_while_paused", &InputStats::ignored_while_paused},
      {"frames_not_keyframes", &InputStats::frames_not_keyframes},
      {"frames_refused_pure_rotation", &InputStats::frames_refused_pure_rotation},
      {"frames_refused_blurred", &InputStats::frames_refused_blurred},
      {"blurred_frames_taken_anyway", &InputStats::blurred_frames_taken_anyway},
      {"keyframes_sent", &InputStats::keyframes_sent},
      {"dropped: encoding", &InputStats::dropped_encoding},
      {"dropped: bad_pose", &InputStats::dropped_bad_pose},
      {"dropped: bad_camera_info", &InputStats::dropped_bad_camera_info},
      {"dropped: bad_keyframe", &InputStats::dropped_bad_keyframe},
      {"dropped: stamp_backwards", &InputStats::dropped_stamp_backwards},
      {"dropped: bad_stamp", &InputStats::dropped_bad_stamp},
      {"dropped: missing_tf", &InputStats::dropped_missing_tf},
      {"dropped: bad_pose_update", &InputStats::dropped_bad_pose_update},
      {"dropped: before_subscriber", &InputStats::dropped_before_subscriber},
      {"clock_jumps_back", &InputStats::clock_jumps_back},
  };
  return fields;
}

MappingInputs::MappingInputs(ros::NodeHandle& nh, ros::NodeHandle& pnh, const MappingConfig& config,
                             Callbacks callbacks)
    : config_(config),
      callbacks_(std::move(callbacks)),
      picker_(config.keyframes),
      started_(ros::WallTime::now()) {
  keyframe_poses_sub_ = nh.subscribe("keyframe_poses", 10, &MappingInputs::keyframePosesCallback, this);
  if (config_.node.input_mode == "keyframe") {
    keyframe_sub_ = nh.subscribe("keyframe", 10, &MappingInputs::keyframeCallback, this);
    frame_topic_ = watch(keyframe_sub_.getTopic(), [this] { return keyframe_sub_.getNumPublishers(); });
    return;
  }
  it_.reset(new image_transport::ImageTransport(nh));
  const uint32_t q = config_.node.sync_queue_size;
  // The base topic resolved here, so that a remap of `image` holds for every
  // transport: this image_transport appends "/compressed" to the unresolved
  // name, and image:=/camera/image gave <ns>/image/compressed.
  image_filter_.reset(new image_transport::SubscriberFilter(
      *it_, nh.resolveName("image"), q, image_transport::TransportHints("raw", ros::TransportHints(), pnh)));
  info_filter_.reset(new message_filters::Subscriber<sensor_msgs::CameraInfo>(nh, "camera_info", q));
  // Arrivals of each topic, before synchronisation (what is silent?).
  frame_topic_ = watchFilter(*image_filter_);
  watchFilter(*info_filter_);
  const ros::Duration max_interval(config_.node.sync_max_interval);
  if (config_.node.input_mode == "pose") {
    pose_filter_.reset(new message_filters::Subscriber<geometry_msgs::PoseStamped>(nh, "pose", q));
    watchFilter(*pose_filter_);
    PoseSync policy(q);
    policy.setMaxIntervalDuration(max_interval);
    pose_sync_.reset(new message_filters::Synchronizer<PoseSync>(static_cast<const PoseSync&>(policy), *image_filter_,
                                                                 *info_filter_, *pose_filter_));
    pose_sync_->registerCallback(&MappingInputs::poseCallback, this);
  } else if (config_.node.input_mode == "odometry") {
    odometry_filter_.reset(new message_filters::Subscriber<nav_msgs::Odometry>(nh, "odom", q));
    watchFilter(*odometry_filter_);
    OdometrySync policy(q);
    policy.setMaxIntervalDuration(max_interval);
    odometry_sync_.reset(new message_filters::Synchronizer<OdometrySync>(
        static_cast<const OdometrySync&>(policy), *image_filter_, *info_filter_, *odometry_filter_));
    odometry_sync_->registerCallback(&MappingInputs::odometryCallback, this);
  } else {
    tf_frames_.reset(new TfFrameFilter(
        nh, config_.node.fixed_frame, config_.node.tf_timeout, q,
        [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
               const geometry_msgs::Pose& pose) { offerImage(image, info, config_.node.fixed_frame, pose); },
        [this](const std::string& reason) { drop(&InputStats::dropped_missing_tf, reason); }));
    CameraSync policy(q);
    policy.setMaxIntervalDuration(max_interval);
    camera_sync_.reset(new message_filters::Synchronizer<CameraSync>(static_cast<const CameraSync&>(policy),
                                                                     *image_filter_, *info_filter_));
    camera_sync_->registerCallback(&MappingInputs::cameraCallback, this);
  }
}

MappingInputs::~MappingInputs() {
  pose_sync_.reset();
  odometry_sync_.reset();
  camera_sync_.reset();
  tf_frames_.reset();
  odometry_filter_.reset();
  image_filter_.reset();
  info_filter_.reset();
  pose_filter_.reset();
  keyframe_sub_.shutdown();
  keyframe_poses_sub_.shutdown();
}

void MappingInputs::setPaused(bool paused) {
  std::lock_guard<std::mutex> lock(input_mutex_);
  paused_ = paused;
}

void MappingInputs::restart() {
  std::lock_guard<std::mutex> lock(input_mutex_);
  last_stamp_ = ros::Time();
  picker_.reset();
}

void MappingInputs::setKeyframePicking(const amhmvs::KeyframePickerOptions& options) {
  std::lock_guard<std::mutex> lock(input_mutex_);
  picker_.setOptions(options);
}

InputStats MappingInputs::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

size_t MappingInputs::watch(const std::string& name, std::function<uint32_t()> publishers) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  topics_.push_back({name, std::move(publishers), ros::WallTime()});
  return topics_.size() - 1;
}

void MappingInputs::noteArrival(size_t topic, uint32_t seq) {
  uint64_t gap = 0;
  std::string name;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    Topic& watched = topics_[topic];
    watched.last_arrival = ros::WallTime::now();
    gap = watched.gaps.arrive(seq);
    ++watched.messages;
    name = watched.name;
  }
  if (gap > 0)
    drop(&InputStats::dropped_before_subscriber,
         std::to_string(gap) + " message(s) on " + name +
             " never reached the subscriber (its queue, ~sync_queue_size, overflowed while the CPU was busy)",
         gap);
}

std::vector<std::pair<std::string, uint64_t>> MappingInputs::messagesLost() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  std::vector<std::pair<std::string, uint64_t>> counts;
  for (const Topic& topic : topics_) counts.push_back({topic.name, topic.gaps.lost()});
  return counts;
}

std::vector<std::pair<std::string, uint64_t>> MappingInputs::messagesReceived() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  std::vector<std::pair<std::string, uint64_t>> counts;
  for (const Topic& topic : topics_) counts.push_back({topic.name, topic.messages});
  return counts;
}

uint64_t MappingInputs::imagesNotSynchronised() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (!image_filter_ || topics_.empty()) return 0;  // keyframe mode: one message is one frame
  // A frame is counted once it leaves the synchroniser (and, in tf mode, the
  // transform's wait).
  const uint64_t images = topics_[frame_topic_].messages;
  const uint64_t frames = stats_.frames_received + stats_.dropped_missing_tf;
  return images > frames ? images - frames : 0;
}

std::vector<std::string> MappingInputs::silenceProblems(double silence_s) const {
  std::vector<std::string> problems;
  const ros::WallTime now = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const auto recent = [&](const ros::WallTime& t) { return !t.isZero() && (now - t).toSec() < silence_s; };
  std::string delivering;  // a topic that delivers now
  for (const Topic& topic : topics_)
    if (recent(topic.last_arrival)) delivering = topic.name;
  if (endedLocked(silence_s)) return problems;  // not a problem: the bag or the camera stopped
  for (const Topic& topic : topics_) {
    if (topic.publishers() == 0) {
      problems.push_back("no publisher on " + topic.name);
    } else if (!delivering.empty() && !recent(topic.last_arrival)) {
      std::ostringstream line;
      line << "nothing on " << topic.name << " for " << (topic.last_arrival.isZero() ? (now - started_).toSec()
                                                                                      : (now - topic.last_arrival).toSec())
           << " s while " << delivering << " delivers";
      problems.push_back(line.str());
    }
  }
  // Every topic delivers but no frame came out of the synchroniser.
  const bool all_deliver = topics_.size() > 1 && std::all_of(topics_.begin(), topics_.end(), [&](const Topic& t) {
                             return recent(t.last_arrival);
                           });
  const bool synchronised = recent(last_synchronised_) || (now - started_).toSec() < silence_s;
  if (all_deliver && !synchronised && config_.node.input_mode != "keyframe") {
    std::ostringstream line;
    line << "messages arrive on every input topic but none synchronise for " << silence_s
         << " s: their stamps differ by more than ~sync_max_interval (" << config_.node.sync_max_interval << " s)";
    problems.push_back(line.str());
  }
  return problems;
}

bool MappingInputs::endedLocked(double silence_s) const {
  const ros::WallTime now = ros::WallTime::now();
  bool any = false;
  for (const Topic& topic : topics_) {
    if (topic.last_arrival.isZero() || (now - topic.last_arrival).toSec() < silence_s) return false;
    any = true;
  }
  return any;
}

bool MappingInputs::inputEnded(double silence_s) const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return endedLocked(silence_s);
}

void MappingInputs::noteSynchronised() {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  last_synchronised_ = ros::WallTime::now();
}

void MappingInputs::count(uint64_t InputStats::*counter) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++(stats_.*counter);
}

void MappingInputs::drop(uint64_t InputStats::*counter, const std::string& detail, uint64_t count) {
  std::string reason = "input";
  for (const InputStatField& field : inputStatFields())
    if (field.value == counter) reason = field.name;
  uint64_t total;
  bool report;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    total = (stats_.*counter += count);
    const ros::WallTime now = ros::WallTime::now();
    ros::WallTime& last = last_report_[reason];
    report = last.isZero() || (now - last).toSec() >= kReportPeriod;
    if (report) last = now;
  }
  if (report) ROS_ERROR("%s: %s [%lu so far]", reason.c_str(), detail.c_str(), static_cast<unsigned long>(total));
}

// ---------------------------------------------------------------- callbacks ---

void MappingInputs::keyframeCallback(const amhmvs_mapping::KeyframeConstPtr& msg) {
  noteArrival(frame_topic_, msg->header.seq);  // keyframe mode: the one topic
  noteSynchronised();
  Frame frame;
  frame.id = msg->keyframe_id;
  frame.header.stamp = msg->header.stamp;
  frame.header.frame_id = !msg->image.header.frame_id.empty() ? msg->image.header.frame_id
                                                              : msg->camera_info.header.frame_id;
  // Aliasing pointers: share ownership of the keyframe message, no copy.
  frame.image = sensor_msgs::ImageConstPtr(msg, &msg->image);
  frame.info = sensor_msgs::CameraInfoConstPtr(msg, &msg->camera_info);
  frame.min_depth = msg->min_depth;
  frame.max_depth = msg->max_depth;
  frame.sparse_points.resize(msg->sparse_points.size());
  for (size_t i = 0; i < msg->sparse_points.size(); ++i) tf2::fromMsg(msg->sparse_points[i], frame.sparse_points[i]);
  offer(std::move(frame), msg->camera_to_world, false);
}

void MappingInputs::keyframePosesCallback(const amhmvs_mapping::KeyframePosesConstPtr& msg) {
  for (const amhmvs_mapping::KeyframePose& entry : msg->poses) {
    Eigen::Isometry3d pose;
    const std::string problem = poseFromMsg(entry.camera_to_world, &pose);
    if (!problem.empty()) {
      drop(&InputStats::dropped_bad_pose_update, "keyframe " + std::to_string(entry.keyframe_id) + ": " + problem);
      continue;
    }
    callbacks_.pose_update(entry.keyframe_id, pose);
  }
}

void MappingInputs::poseCallback(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                                 const geometry_msgs::PoseStampedConstPtr& pose) {
  noteSynchronised();
  offerImage(image, info, pose->header.frame_id, pose->pose);
}

void MappingInputs::odometryCallback(const sensor_msgs::ImageConstPtr& image,
                                     const sensor_msgs::CameraInfoConstPtr& info,
                                     const nav_msgs::OdometryConstPtr& odometry) {
  noteSynchronised();
  offerImage(image, info, odometry->header.frame_id, odometry->pose.pose);
}

void MappingInputs::offerImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                               const std::string& pose_frame, const geometry_msgs::Pose& pose) {
  if (!pose_frame.empty() && pose_frame != config_.node.fixed_frame) {
    ROS_WARN_ONCE("%s frame '%s' is not ~fixed_frame '%s': the poses are used as they are",
                  config_.node.input_mode.c_str(), pose_frame.c_str(), config_.node.fixed_frame.c_str());
  }
  Frame frame;
  frame.header = image->header;
  frame.image = image;
  frame.info = info;
  offer(std::move(frame), pose, true);
}

void MappingInputs::cameraCallback(const sensor_msgs::ImageConstPtr& image,
                                   const sensor_msgs::CameraInfoConstPtr& info) {
  noteSynchronised();
  tf_frames_->add(image, info);  // on to offerImage() once tf has the pose
}

void MappingInputs::offer(Frame frame, const geometry_msgs::Pose& pose, bool pick) {
  count(&InputStats::frames_received);
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    if (paused_) {
      count(&InputStats::ignored_while_paused);
      return;
    }
  }
  if (!supportedEncoding(frame.image->encoding)) {
    drop(&InputStats::dropped_encoding, "image encoding '" + frame.image->encoding +
                                            "' is not mono8, mono16, rgb8, bgr8, rgba8, bgra8 or bayer_*8");
    return;
  }
  std::string problem = poseFromMsg(pose, &frame.camera_to_world);
  if (!problem.empty()) {
    drop(&InputStats::dropped_bad_pose, problem);
    return;
  }
  amhmvs::PinholeCamera camera;
  problem = cameraFromMsg(*frame.info, frame.image->width, frame.image->height, frame.camera_to_world, &camera);
  if (!problem.empty()) {
    drop(&InputStats::dropped_bad_camera_info, problem);
    return;
  }
  if (frame.header.stamp.isZero()) {
    drop(&InputStats::dropped_bad_stamp, "stamp is zero (the sender did not fill the header)");
    return;
  }
  amhmvs::ImageU8 converted;
  const ros::Time now = ros::Time::now();
  if (!now.isZero() && (frame.header.stamp - now).toSec() > kMaxStampAheadSeconds) {
    std::ostringstream out;
    out << "stamp " << frame.header.stamp << " is more than a day ahead of the clock (" << now << ")";
    drop(&InputStats::dropped_bad_stamp, out.str());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    // A clock that went back (a bag played again, a simulator restarted):
    // the input starts again from the new time, as tf2's listener clears its
    // buffer then; the map stays (~reset starts a new one). Frames stamped
    // after the new time were sent before the jump (the synchroniser may
    // still hold some): dropped until the first one of the new time.
    if (!now.isZero() && !last_clock_.isZero() && now < last_clock_) {
      count(&InputStats::clock_jumps_back);
      // A looped bag jumps at every loop: at most a line a minute.
      ROS_WARN_STREAM_THROTTLE(60, "the clock jumped back from "
                                       << last_clock_ << " to " << now
                                       << ": input stamps start again from there; the map is kept (call ~reset to "
                                          "start a new one) ["
                                       << stats().clock_jumps_back << " jumps so far]");
      last_stamp_ = ros::Time();
      clock_restarted_ = true;
    }
    if (!now.isZero()) last_clock_ = now;
    if (clock_restarted_ && frame.header.stamp > now) {
      std::ostringstream out;
      out << "stamp " << frame.header.stamp << " was sent before the clock jumped back to " << now;
      drop(&InputStats::dropped_stamp_backwards, out.str());
      return;
    }
    clock_restarted_ = false;
    if (!last_stamp_.isZero() && frame.header.stamp < last_stamp_) {
      std::ostringstream out;
      out << "stamp " << frame.header.stamp << " is before the previous input's " << last_stamp_
          << " while the clock did not go back (call ~reset to start again)";
      drop(&InputStats::dropped_stamp_backwards, out.str());
      return;
    }
    last_stamp_ = frame.header.stamp;
    if (pick) {
      // The image is converted only for candidates, once: the keyframe reuses it.
      const auto sharpness = [&frame, &converted] {
        // Not judged (NaN) when it cannot be converted: toKeyframe reports why.
        return imageFromMsg(*frame.image, &converted).empty() ? amhmvs::imageSharpness(converted) : std::nan("");
      };
      const amhmvs::KeyframePickerStats before = picker_.stats();
      const amhmvs::PickDecision decision = picker_.offer(frame.camera_to_world, sharpness);
      if (picker_.stats().blurred_taken_anyway > before.blurred_taken_anyway)
        count(&InputStats::blurred_frames_taken_anyway);
      switch (decision) {
        case amhmvs::PickDecision::kKeyframe: break;
        case amhmvs::PickDecision::kTooClose:
          count(&InputStats::frames_not_keyframes);
          offerBetweenKeyframes(frame, std::move(converted));
          return;
        case amhmvs::PickDecision::kPureRotation: count(&InputStats::frames_refused_pure_rotation); return;
        case amhmvs::PickDecision::kBlurred: count(&InputStats::frames_refused_blurred); return;
      }
      frame.id = next_id_++;
    }
  }
  amhmvs::Keyframe keyframe;
  try {
    keyframe = toKeyframe(frame, std::move(converted));
  } catch (const amhmvs::InputError& e) {
    drop(&InputStats::dropped_bad_keyframe, "keyframe " + std::to_string(frame.id) + ": " + e.what());
    return;
  }
  count(&InputStats::keyframes_sent);
  callbacks_.keyframe(std::move(keyframe), frame.header);
}

void MappingInputs::offerBetweenKeyframes(const Frame& frame, amhmvs::ImageU8 converted) {
  if (!callbacks_.frame || !config_.pipeline.mapper.depth_filter.enabled) return;
  try {
    callbacks_.frame(toKeyframe(frame, std::move(converted)));
  } catch (const amhmvs::InputError& e) {
    // Counted as a frame that is no keyframe already; the filter only misses it.
    ROS_DEBUG_THROTTLE(10, "frame between keyframes not used by the depth filter: %s", e.what());
  }
}

amhmvs::Keyframe MappingInputs::toKeyframe(const Frame& frame, amhmvs::ImageU8 converted) const {
  amhmvs::Keyframe keyframe;
  keyframe.id = frame.id;
  keyframe.stamp = frame.header.stamp.toSec();
  keyframe.image = std::move(converted);
  std::string problem = keyframe.image.empty() ? imageFromMsg(*frame.image, &keyframe.image) : std::string();
  if (problem.empty())
    problem = cameraFromMsg(*frame.info, keyframe.image.width, keyframe.image.height, frame.camera_to_world,
                            &keyframe.camera);
  if (!problem.empty()) throw amhmvs::InputError(problem);
  // Undistorted to the pinhole with the same K (what depth/camera_info says).
  rectifier_.undistort(*frame.info, &keyframe.image);
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

}  // namespace amhmvs_mapping
