#include "amhmvs_mapping/ros/mapping_nodelet.h"

#include <cstdlib>

#include <boost/filesystem.hpp>
#include <pluginlib/class_list_macros.hpp>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/map_export.h"
#include "amhmvs_mapping/ros/mapping_tunables.h"

namespace amhmvs_mapping {

MappingNodelet::~MappingNodelet() {
  inputs_.reset();  // first: no callback feeds a stopping worker
  stop_ = true;
  if (pipeline_) pipeline_->wake();
  // Bounded: the worker ends after the step it is in (one keyframe at most).
  if (worker_.joinable()) worker_.join();
  if (pipeline_ && !config_.node.save_map_on_shutdown.empty()) {
    try {
      NODELET_INFO("shutting down: %s", saveMap(config_.node.save_map_on_shutdown).c_str());
    } catch (const std::exception& e) {
      NODELET_ERROR("shutting down: save_map_on_shutdown failed: %s", e.what());
    }
  }
}

void MappingNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  const LoadedConfig loaded = loadMappingConfig(pnh);
  config_ = loaded.config;
  if (!loaded.errors.empty()) NODELET_ERROR("invalid parameters, defaults used instead:\n%s", loaded.errors.c_str());
  for (const std::string& unknown : loaded.unknown) NODELET_WARN("unknown parameter ~%s: ignored", unknown.c_str());
  unknown_parameters_ = loaded.unknown;
  if (config_.node.map_directory.empty()) {
    const char* pwd = std::getenv("PWD");  // roslaunch's own directory (a node runs in ~/.ros)
    config_.node.map_directory = pwd ? pwd : boost::filesystem::current_path().string();
  }

  const amhmvs::PipelineOptions& options = config_.pipeline;
  const std::string name = getName();
  pipeline_.reset(new amhmvs::MappingPipeline(options, [name](amhmvs::MappingPipeline::LogLevel level,
                                                              const std::string& line) {
    switch (level) {
      case amhmvs::MappingPipeline::LogLevel::kDebug: ROS_DEBUG_STREAM_NAMED(name, line); break;
      case amhmvs::MappingPipeline::LogLevel::kInfo: ROS_INFO_STREAM_NAMED(name, line); break;
      case amhmvs::MappingPipeline::LogLevel::kWarn: ROS_WARN_STREAM_NAMED(name, line); break;
      default: ROS_ERROR_STREAM_NAMED(name, line);
    }
  }));

  // Auto size: known once the backend is (the CPU's fallback included).
  config_.max_image_size = amhmvs::effectiveMaxImageSize(config_.max_image_size, pipeline_->backend());

  outputs_.reset(new MappingOutputs(nh, config_, [this] {
    map_requested_ = true;
    pipeline_->wake();
  }));

  save_map_srv_ = pnh.advertiseService("save_map", &MappingNodelet::saveMapService, this);
  reset_srv_ = pnh.advertiseService("reset", &MappingNodelet::resetService, this);
  pause_srv_ = pnh.advertiseService("pause", &MappingNodelet::pauseService, this);
  resume_srv_ = pnh.advertiseService("resume", &MappingNodelet::resumeService, this);

  diagnostics_.reset(new diagnostic_updater::Updater(nh, pnh, getName()));
  diagnostics_->setHardwareID("amhmvs_mapping");
  diagnostics_->add("depth estimation", this, &MappingNodelet::diagnose);
  // Wall timer: simulated time stops when a bag ends, the worker may not.
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(config_.node.diagnostics_period),
                                          [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });

  // Runtime tunables, starting from the loaded parameters.
  reconfigured_ = config_;
  reconfigure_server_.reset(new dynamic_reconfigure::Server<MappingTunablesConfig>(reconfigure_mutex_, pnh));
  MappingTunablesConfig initial = tunablesFrom(config_);
  reconfigure_server_->updateConfig(initial);
  reconfigure_server_->setCallback(
      [this](MappingTunablesConfig& tunables, uint32_t level) { reconfigure(tunables, level); });

  worker_ = std::thread(&MappingNodelet::workerLoop, this);

  MappingInputs::Callbacks callbacks;
  callbacks.keyframe = [this](amhmvs::Keyframe keyframe, const std_msgs::Header& header) {
    headers_.set(keyframe.id, header);
    pipeline_->push(std::move(keyframe));
  };
  callbacks.pose_update = [this](int64_t id, const Eigen::Isometry3d& pose) { pipeline_->pushPoseUpdate(id, pose); };
  callbacks.frame = [this](amhmvs::Keyframe frame) { pipeline_->observe(std::move(frame)); };
  inputs_.reset(new MappingInputs(nh, pnh, config_, std::move(callbacks)));
  NODELET_INFO("amhmvs mapping: input mode %s, queue %zu, up to %d sources, default depth %.2f..%.2f m, "
               "max image size %d, voxel size %.3f m (published with %d or more points), backend %s",
               config_.node.input_mode.c_str(), config_.pipeline.queue_size, config_.pipeline.mapper.sources.max_sources,
               config_.pipeline.mapper.depth_range.default_min, config_.pipeline.mapper.depth_range.default_max,
               config_.max_image_size, config_.pipeline.mapper.map.leaf_size, config_.pipeline.mapper.map.min_points_per_voxel,
               amhmvs::backendName(pipeline_->backend()));
}

void MappingNodelet::workerLoop() {
  while (!stop_) {
    const std::vector<amhmvs::PipelineOutput> outputs = pipeline_->step();
    for (const amhmvs::PipelineOutput& output : outputs) {
      const amhmvs::KeyframeResult& result = output.result;
      if (result.fused_again)
        NODELET_INFO("keyframe %ld: fused and published again with %zu consistency views", static_cast<long>(result.id),
                     result.fused.empty() ? size_t{0} : result.fused.front().consistency_ids.size());
      if (result.late || result.refined)
        NODELET_INFO("keyframe %ld: %s depth map from %zu source views", static_cast<long>(result.id),
                     result.late ? "late" : "refined", result.selection.source_ids.size());
      NODELET_DEBUG("keyframe %ld%s: %zu sources, depth %.2f..%.2f m (%s), %.0f ms estimate, %.0f ms in all; "
                    "%zu keyframes fused, %zu wait",
                    static_cast<long>(result.id), result.late ? " (late)" : result.refined ? " (refined)" : "",
                    result.selection.source_ids.size(), result.depth_range.min, result.depth_range.max,
                    amhmvs::depthRangeSourceName(result.depth_range.source), result.times.estimate_ms,
                    result.times.total_ms, result.fused.size(), result.waiting_for_fusion);
      outputs_->publish(result, headers_, *pipeline_);
      for (int64_t id : result.evicted) headers_.erase(id);
      for (int64_t id : result.evicted_before_fusion)
        NODELET_WARN("keyframe %ld: evicted from the store before it could be fused (never in the map)",
                     static_cast<long>(id));
    }
    outputs_->publishMap(*pipeline_, map_requested_.exchange(false));
    // Nothing was done: wait for input, at most a map period (a changed map
    // not yet published then goes out).
    if (outputs.empty() && pipeline_->stats().idle) pipeline_->waitForWork(config_.node.map_publish_period);
  }
}

bool MappingNodelet::saveMapService(amhmvs_mapping::SaveMap::Request& req, amhmvs_mapping::SaveMap::Response& res) {
  try {
    res.message = saveMap(req.path);
    res.success = true;
    NODELET_INFO("%s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("save_map failed: ") + e.what();
    NODELET_ERROR("%s", res.message.c_str());
  }
  return true;
}

std::string MappingNodelet::saveMap(const std::string& requested) {
  if (requested.empty()) throw amhmvs::InputError("empty path: give a file name ending in .ply or .pcd");
  // Relative paths go to ~map_directory (default: where roslaunch was
  // started, not the node's working directory ~/.ros).
  const boost::filesystem::path path = boost::filesystem::absolute(requested, config_.node.map_directory);
  std::string message;
  pipeline_->withMapper([&](const amhmvs::OnlineMapper& mapper) {
    amhmvs::writeMap(path.string(), mapper.map());
    message = "saved " + std::to_string(mapper.map().voxelCount()) + " points to " + path.string();
    if (!mapper.surface()) return;
    // The surface beside it: NAME_mesh.ply.
    boost::filesystem::path mesh_path = path;
    mesh_path.replace_extension();
    mesh_path += "_mesh.ply";
    const amhmvs::TriangleMesh mesh = mapper.surface()->mesh();
    amhmvs::writeMeshPly(mesh_path.string(), mesh);
    message += ", the surface mesh (" + std::to_string(mesh.triangles.size()) + " triangles) to " + mesh_path.string();
  });
  return message;
}

void MappingNodelet::reconfigure(MappingTunablesConfig& tunables, uint32_t /*level*/) {
  try {
    applyTunables(tunables, &reconfigured_);
  } catch (const amhmvs::InputError& e) {
    NODELET_ERROR("reconfigure: %s (unchanged)", e.what());
    return;
  }
  if (inputs_) {
    try {
      inputs_->setKeyframePicking(reconfigured_.keyframes);
    } catch (const amhmvs::InputError& e) {
      NODELET_ERROR("reconfigure: %s (keyframe picking unchanged)", e.what());
    }
  }
  pipeline_->setOptions(reconfigured_.pipeline.mapper, reconfigured_.pipeline.estimator);
  NODELET_INFO("reconfigured: %d iterations, up to %d sources, voxel size %.3f m, published with %d or more points "
               "(applied before the next keyframe)",
               reconfigured_.pipeline.estimator.num_iterations, reconfigured_.pipeline.mapper.sources.max_sources,
               reconfigured_.pipeline.mapper.map.leaf_size, reconfigured_.pipeline.mapper.map.min_points_per_voxel);
}

bool MappingNodelet::resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  const size_t cleared = pipeline_->requestReset();
  inputs_->restart();
  headers_.clear();
  outputs_->replaceViewFrame();
  res.success = true;
  res.message = "reset: " + std::to_string(cleared) + " queued keyframes discarded, stored keyframes cleared";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

bool MappingNodelet::pauseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  paused_ = true;
  inputs_->setPaused(true);
  res.success = true;
  res.message = "paused: new input is ignored until ~resume";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

bool MappingNodelet::resumeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  paused_ = false;
  inputs_->setPaused(false);
  res.success = true;
  res.message = "resumed";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

void MappingNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const amhmvs::PipelineStats pipeline = pipeline_->stats();
  const InputStats input = inputs_ ? inputs_->stats() : InputStats();
  const uint64_t dropped = pipeline.droppedTotal() + input.droppedTotal();
  const ros::WallTime now = ros::WallTime::now();
  // Drops within the window: a WARN that clears once drops stop.
  drop_history_.emplace_back(now, dropped);
  while (drop_history_.size() > 1 && (now - drop_history_[1].first).toSec() >= config_.node.drop_warning_window)
    drop_history_.pop_front();
  const uint64_t recent_drops = dropped - drop_history_.front().second;
  const std::vector<std::string> silence = inputs_ ? inputs_->silenceProblems(config_.node.silence_timeout)
                                                   : std::vector<std::string>();
  std::string silence_text;
  for (const std::string& line : silence) silence_text += (silence_text.empty() ? "" : "; ") + line;
  const bool ended = inputs_ && inputs_->inputEnded(config_.node.silence_timeout);
  if (ended && !input_ended_)
    NODELET_INFO("input ended: nothing on any input topic for %.0f s; %s", config_.node.silence_timeout,
                 pipeline.idle ? "all keyframes are mapped (idle)" : "mapping the queued keyframes");
  if (ended && pipeline.idle && !idle_reported_) {
    NODELET_INFO("idle: every keyframe received is mapped (call ~save_map to write the map)");
    idle_reported_ = true;
  }
  input_ended_ = ended;
  if (!ended) idle_reported_ = false;
  if (ended && recent_drops == 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "input ended, %s (%lu inputs dropped in all)",
                    pipeline.idle ? "idle" : "mapping the queued keyframes", static_cast<unsigned long>(dropped));
  } else if (!silence.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, silence_text);
    if (last_silence_report_.isZero() || (now - last_silence_report_).toSec() >= config_.node.silence_timeout) {
      NODELET_WARN("inputs: %s", silence_text.c_str());
      last_silence_report_ = now;
    }
  } else if (recent_drops > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu inputs dropped in the last %.0f s (%lu in all)",
                    static_cast<unsigned long>(recent_drops), config_.node.drop_warning_window,
                    static_cast<unsigned long>(dropped));
  } else {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "%s (%lu inputs dropped in all)", paused_ ? "paused" : "ok",
                    static_cast<unsigned long>(dropped));
  }
  status.add("dropped in window", recent_drops);
  std::string unknown;
  for (const std::string& name : unknown_parameters_) unknown += (unknown.empty() ? "" : "; ") + name;
  status.add("unknown parameters", unknown.empty() ? "none" : unknown);
  status.add("backend", pipeline.backend);
  status.add("input mode", config_.node.input_mode);
  status.add("paused", static_cast<bool>(paused_));
  status.add("idle", pipeline.idle);
  status.add("last estimate ms", pipeline.last_estimate_ms);
  status.add("last keyframe ms", pipeline.last_total_ms);
  status.add("gpu memory MiB", pipeline.gpu_memory_bytes / double(1 << 20));
  status.add("map_publications", outputs_->mapPublications());
  if (!last_rate_time_.isZero() && now > last_rate_time_)
    status.add("input rate hz", (input.frames_received - last_rate_frames_) / (now - last_rate_time_).toSec());
  last_rate_time_ = now;
  last_rate_frames_ = input.frames_received;
  for (const InputStatField& field : inputStatFields()) status.add(field.name, input.*field.value);
  if (inputs_) {
    for (const auto& [topic, messages] : inputs_->messagesReceived()) status.add("received on " + topic, messages);
    for (const auto& [topic, messages] : inputs_->messagesLost()) status.add("lost on " + topic, messages);
    status.add("images_not_synchronised", inputs_->imagesNotSynchronised());
  }
  for (const amhmvs::PipelineStatField& field : amhmvs::pipelineStatFields())
    status.add(field.name, pipeline.*field.value);
}

}  // namespace amhmvs_mapping

PLUGINLIB_EXPORT_CLASS(amhmvs_mapping::MappingNodelet, nodelet::Nodelet)
