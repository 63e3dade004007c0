// Parameters of the mapping nodelet (all under its private namespace; see
// config/mapping.yaml for the documented defaults). The mapping core's option
// structs are filled from parameter groups (store/, sources/, depth_range/,
// fusion/, map/, estimator/), each checked by its own validate().
#pragma once

#include <string>

#include <ros/node_handle.h>

#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs_mapping {

struct MappingConfig {
  // --- Input ---
  std::string input_mode = "pose";   // "pose" (image + camera_info + PoseStamped), "odometry", "tf", "keyframe"
  std::string fixed_frame = "world"; // tf mode: pose = fixed_frame <- image frame
  // tf frame (child of fixed_frame) where the first keyframe with depth looked
  // (view_anchor.h): the rviz config's view target; empty: not published.
  std::string view_frame = "amhmvs_view";
  double tf_timeout = 0.1;           // wall seconds to wait for a transform (tf mode)
  // Bounded input queue of keyframes (drop-oldest). 32 holds the bursts of
  // the bags (11-16 keyframes in 3-5 s) while the CPU estimates for seconds.
  int queue_size = 32;
  bool skip_to_newest = true;        // after a queue overflow take the newest keyframe (PipelineOptions)
  int sync_queue_size = 10;          // approximate-time synchroniser queue
  double sync_max_interval = 0.05;   // seconds between synchronised stamps
  // Keyframe picking (pose, odometry and tf modes; mapping/keyframe_picker.h):
  // a frame is a candidate when it moved at least this far from the last
  // keyframe (either criterion) ... The defaults are the core picker's, the
  // ones amhmvs_map uses: 5 cm / 5 deg (10 cm / 10 deg until session 16 left
  // the redkitchen bag's last keyframes with sources too far apart).
  double keyframe_min_translation = amhmvs::KeyframePickerOptions().min_translation_m;    // metres
  double keyframe_min_rotation_deg = amhmvs::KeyframePickerOptions().min_rotation_deg;  // degrees
  // ... and is refused as a pure rotation when it moved less than this
  // fraction of keyframe_min_translation (0: off), or as blurred when its
  // sharpness is below this fraction of the recent candidates' median (0: off).
  double keyframe_min_turning_translation = amhmvs::KeyframePickerOptions().min_turning_translation_fraction;
  double keyframe_min_relative_sharpness = amhmvs::KeyframePickerOptions().min_relative_sharpness;

  amhmvs::KeyframePickerOptions keyframePicking() const;

  // --- Estimation ---
  std::string backend = "auto";      // auto, cuda, cpu
  // Downscale so that max(width, height) <= this; 0 = full size; -1 = auto:
  // full size on the GPU, kCpuAutoMaxImageSize on the CPU (effectiveMaxImageSize).
  int max_image_size = -1;
  amhmvs::PatchMatchOptions estimator;  // ~estimator/<option name>

  // --- Mapping core: ~store/, ~sources/, ~depth_range/, ~fusion/, ~map/ ---
  amhmvs::OnlineMapperOptions mapper = defaultMapperOptions();

  // --- Output ---
  // Also publish depth_mm/image (16UC1 millimetres, 0 invalid) + camera_info.
  bool publish_depth_mm = false;
  double map_publish_period = 2.0;   // at most one map publication per this many seconds (on change)
  double diagnostics_period = 1.0;   // seconds
  // Diagnostics go WARN (and the log says which topics) when an input topic
  // has no publisher, or stays silent this long while the others deliver.
  double silence_timeout = 5.0;      // seconds
  // Drops make diagnostics WARN while any happened within this window.
  double drop_warning_window = 10.0;  // seconds
  // Where ~save_map puts relative paths; empty: the directory roslaunch (or
  // the node) was started from ($PWD).
  std::string map_directory;

  // The mapping core's defaults for online use (a bounded store of 50).
  static amhmvs::OnlineMapperOptions defaultMapperOptions();
};

// The CPU takes seconds per 320 px depth map on 2 cores and minutes at full
// size: auto picks this on the CPU.
constexpr int kCpuAutoMaxImageSize = 320;

// The image size limit in use: `configured`, or for -1 (auto) full size (0)
// on the GPU and kCpuAutoMaxImageSize on the CPU.
int effectiveMaxImageSize(int configured, amhmvs::Backend backend);

// Reads the parameters that are set under `pnh` into a config (unset ones keep
// their defaults). Invalid values are reported in `errors` (one line each) and
// replaced by the defaults (a whole group when its validate() fails).
MappingConfig loadMappingConfig(const ros::NodeHandle& pnh, std::string* errors);

}  // namespace amhmvs_mapping
