// amhmvs_mapping/MappingNodelet: online dense mapping of SLAM keyframes.
//
// Wiring only: inputs (mapping_inputs.h: input modes, tf, keyframe picking,
// checks) -> amhmvs::MappingPipeline (ROS-free: queue, estimator with CPU
// fallback, new / late / refine scheduling, fusion, voxel map) -> outputs
// (mapping_outputs.h: depth, confidence, preview, keyframe clouds, map,
// markers). onInit only wires up; the pipeline runs on a worker thread.
// Services: ~save_map (SaveMap: .ply or .pcd), ~reset, ~pause, ~resume.
// /diagnostics: the pipeline's and the inputs' typed counters.
// dynamic_reconfigure: the runtime tunables (cfg/MappingTunables.cfg).
#pragma once

#include <atomic>
#include <deque>
#include <utility>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include "amhmvs_mapping/MappingTunablesConfig.h"
#include "amhmvs_mapping/SaveMap.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "amhmvs_mapping/ros/mapping_config.h"
#include "amhmvs_mapping/ros/mapping_inputs.h"
#include "amhmvs_mapping/ros/mapping_outputs.h"

namespace amhmvs_mapping {

class MappingNodelet : public nodelet::Nodelet {
 public:
  MappingNodelet() = default;
  ~MappingNodelet() override;

 private:
  void onInit() override;
  // Worker thread: steps the pipeline and publishes its results.
  void workerLoop();

  bool saveMapService(amhmvs_mapping::SaveMap::Request& req, amhmvs_mapping::SaveMap::Response& res);
  // Writes the global map to `path` (relative: under ~map_directory); the
  // message for the log. Throws on an empty or bad path and on a failed write.
  std::string saveMap(const std::string& path);
  bool resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool pauseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool resumeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  // dynamic_reconfigure: keyframe picking at once, the rest by the pipeline
  // before its next step.
  void reconfigure(MappingTunablesConfig& tunables, uint32_t level);

  MappingConfig config_;
  std::unique_ptr<amhmvs::MappingPipeline> pipeline_;
  std::unique_ptr<MappingInputs> inputs_;
  std::unique_ptr<MappingOutputs> outputs_;
  KeyframeHeaders headers_;

  ros::ServiceServer save_map_srv_, reset_srv_, pause_srv_, resume_srv_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;
  boost::recursive_mutex reconfigure_mutex_;  // the type dynamic_reconfigure takes
  std::unique_ptr<dynamic_reconfigure::Server<MappingTunablesConfig>> reconfigure_server_;
  MappingConfig reconfigured_;  // the reconfigure callback's copy

  std::thread worker_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> map_requested_{false};  // a subscriber connected to ~map
  // Input rate over the diagnostics period.
  ros::WallTime last_rate_time_;
  uint64_t last_rate_frames_ = 0;
  // Drop totals at past diagnostics updates, for the drops within
  // ~drop_warning_window (WARN clears when drops stop).
  std::deque<std::pair<ros::WallTime, uint64_t>> drop_history_;
  ros::WallTime last_silence_report_;
  bool input_ended_ = false;    // at the last diagnose: "input ended" is logged when this turns true
  bool idle_reported_ = false;  // "idle" logged since the input ended
  std::vector<std::string> unknown_parameters_;  // under the private namespace, reported in diagnostics
};

}  // namespace amhmvs_mapping
