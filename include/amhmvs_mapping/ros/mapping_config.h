// Parameters of the mapping nodelet (all under its private namespace; see
// config/mapping.yaml for the documented defaults).
#pragma once

#include <string>

#include <ros/node_handle.h>

#include "amhmvs_mapping/mvs/patchmatch_options.h"
#include "amhmvs_mapping/ros/source_views.h"

namespace amhmvs_mapping {

struct MappingConfig {
  // --- Input ---
  std::string input_mode = "pose";   // "pose" (image + camera_info + PoseStamped), "tf", "keyframe"
  std::string fixed_frame = "world"; // tf mode: pose = fixed_frame <- image frame
  double tf_timeout = 0.1;           // wall seconds to wait for a transform (tf mode)
  int queue_size = 4;                // bounded input queue (drop-oldest)
  int sync_queue_size = 10;          // approximate-time synchroniser queue
  double sync_max_interval = 0.05;   // seconds between synchronised stamps
  // Keyframe picking (pose and tf modes): a frame becomes a keyframe when it
  // moved at least this far from the last keyframe (either criterion).
  double keyframe_min_translation = 0.1;   // metres
  double keyframe_min_rotation_deg = 10.0; // degrees
  int max_keyframes = 20;            // stored keyframes (source views), oldest evicted

  // --- Source views ---
  SourceViewOptions sources;         // num_sources, min/max_baseline, max_source_angle_deg

  // --- Estimation ---
  double min_depth = 0.1, max_depth = 20.0;  // default z-depth range (metres)
  std::string backend = "auto";      // auto, cuda, cpu
  int max_image_size = 0;            // downscale so that max(width, height) <= this; 0 = off
  amhmvs::PatchMatchOptions estimator;  // ~estimator/<option name>

  // --- Output ---
  double cloud_max_cost = 0.6;       // keyframe_cloud: pixels with cost <= this (cost in [0, 2])
  double diagnostics_period = 1.0;   // seconds
};

// Reads the parameters that are set under `pnh` into a config (unset ones keep
// their defaults). Invalid values are reported in `errors` (one line each) and
// replaced by the defaults.
MappingConfig loadMappingConfig(const ros::NodeHandle& pnh, std::string* errors);

}  // namespace amhmvs_mapping
