#include "amhmvs_mapping/ros/mapping_config.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <XmlRpcValue.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs_mapping {
namespace {

// A scalar parameter as text (for the option table's setters).
bool paramText(const ros::NodeHandle& nh, const std::string& name, std::string* text) {
  XmlRpc::XmlRpcValue value;
  if (!nh.getParam(name, value)) return false;
  std::ostringstream out;
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: out << (static_cast<bool>(value) ? "true" : "false"); break;
    case XmlRpc::XmlRpcValue::TypeInt: out << static_cast<int>(value); break;
    case XmlRpc::XmlRpcValue::TypeDouble: out.precision(17); out << static_cast<double>(value); break;
    case XmlRpc::XmlRpcValue::TypeString: out << static_cast<std::string>(value); break;
    default: return false;
  }
  *text = out.str();
  return true;
}

// Typed reads of optional parameters (unset: the value stays).
void read(const ros::NodeHandle& nh, const std::string& name, double* value) { nh.param(name, *value, *value); }
void read(const ros::NodeHandle& nh, const std::string& name, int* value) { nh.param(name, *value, *value); }
void read(const ros::NodeHandle& nh, const std::string& name, bool* value) { nh.param(name, *value, *value); }
void read(const ros::NodeHandle& nh, const std::string& name, std::string* value) {
  nh.param(name, *value, *value);
}
void read(const ros::NodeHandle& nh, const std::string& name, size_t* value) {
  int v = static_cast<int>(*value);
  nh.param(name, v, v);
  *value = v < 0 ? 0 : static_cast<size_t>(v);
}
// A point [x, y, z]; [] keeps the value (unbounded); a list of another
// length reads as NaN, which the options' validate() reports.
void read(const ros::NodeHandle& nh, const std::string& name, Eigen::Vector3d* value) {
  std::vector<double> list;
  if (!nh.getParam(name, list) || list.empty()) return;
  *value = list.size() == 3 ? Eigen::Vector3d(list[0], list[1], list[2])
                            : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
}
// Fusion thresholds: 0 on the parameter server switches a check off
// (FusionOptions uses +infinity, which XML-RPC cannot carry).
void readThreshold(const ros::NodeHandle& nh, const std::string& name, float* value) {
  double v = std::isinf(*value) ? 0.0 : *value;
  nh.param(name, v, v);
  *value = v == 0 ? amhmvs::FusionOptions::kOff : static_cast<float>(v);
}

void readMapperOptions(const ros::NodeHandle& nh, amhmvs::OnlineMapperOptions* o) {
  read(nh, "store/max_keyframes", &o->store.max_keyframes);
  double max_mib = static_cast<double>(o->store.max_bytes) / (1 << 20);
  read(nh, "store/max_memory_mb", &max_mib);
  o->store.max_bytes = max_mib > 0 ? static_cast<size_t>(max_mib * (1 << 20)) : 0;

  read(nh, "sources/max_sources", &o->sources.max_sources);
  read(nh, "sources/min_triangulation_angle_deg", &o->sources.min_triangulation_angle_deg);
  read(nh, "sources/max_triangulation_angle_deg", &o->sources.max_triangulation_angle_deg);
  read(nh, "sources/max_axis_angle_deg", &o->sources.max_axis_angle_deg);
  read(nh, "sources/min_overlap", &o->sources.min_overlap);
  read(nh, "sources/preferred_angle_deg", &o->sources.preferred_angle_deg);
  read(nh, "sources/match_when_unknown", &o->sources.match_when_unknown);
  read(nh, "sources/default_scene_depth", &o->sources.default_scene_depth);

  read(nh, "depth_range/use_given_range", &o->depth_range.use_given_range);
  read(nh, "depth_range/near_factor", &o->depth_range.near_factor);
  read(nh, "depth_range/far_factor", &o->depth_range.far_factor);
  read(nh, "depth_range/min_sparse_points", &o->depth_range.min_sparse_points);
  read(nh, "depth_range/min_depth_samples", &o->depth_range.min_depth_samples);
  read(nh, "depth_range/max_neighbour_cost", &o->depth_range.max_neighbour_cost);
  read(nh, "depth_range/neighbour_low_percentile", &o->depth_range.neighbour_low_percentile);
  read(nh, "depth_range/neighbour_high_percentile", &o->depth_range.neighbour_high_percentile);
  read(nh, "depth_range/match_when_unknown", &o->depth_range.match_when_unknown);
  read(nh, "depth_range/default_min", &o->depth_range.default_min);
  read(nh, "depth_range/default_max", &o->depth_range.default_max);

  readThreshold(nh, "fusion/max_reprojection_error", &o->fusion.max_reprojection_error);
  readThreshold(nh, "fusion/max_relative_depth_difference", &o->fusion.max_relative_depth_difference);
  readThreshold(nh, "fusion/max_disparity_difference", &o->fusion.max_disparity_difference);
  readThreshold(nh, "fusion/max_normal_angle_deg", &o->fusion.max_normal_angle_deg);
  readThreshold(nh, "fusion/max_cost", &o->fusion.max_cost);
  read(nh, "fusion/min_consistent_views", &o->fusion.min_consistent_views);

  read(nh, "map/voxel_size", &o->map.leaf_size);
  read(nh, "map/max_voxels", &o->map.max_voxels);
  read(nh, "map/min_points_per_voxel", &o->map.min_points_per_voxel);
  read(nh, "map/region_min", &o->map.region_min);
  read(nh, "map/region_max", &o->map.region_max);

  read(nh, "refinement/max_refinements", &o->refinement.max_refinements);
  read(nh, "refinement/min_score_gain", &o->refinement.min_score_gain);
  read(nh, "refinement/keep_only_better", &o->refinement.keep_only_better);
  read(nh, "refinement/confident_cost", &o->refinement.confident_cost);
  read(nh, "refinement/max_confident_loss", &o->refinement.max_confident_loss);
  read(nh, "refinement/fuse_neighbours_again", &o->refinement.fuse_neighbours_again);

  read(nh, "rolling_shutter/readout_s", &o->rolling_shutter.readout_s);
  read(nh, "rolling_shutter/max_interval_s", &o->rolling_shutter.max_interval_s);
  read(nh, "rolling_shutter/use_tracker_velocity", &o->rolling_shutter.use_tracker_velocity);
  read(nh, "rolling_shutter/translation", &o->rolling_shutter.translation);
  read(nh, "rolling_shutter/from_adjusted_poses", &o->rolling_shutter.from_adjusted_poses);
  read(nh, "rolling_shutter/tracker_velocity_sigma_rad_s", &o->rolling_shutter.tracker_velocity_sigma_rad_s);
  read(nh, "rolling_shutter/tracker_velocity_sigma_m_s", &o->rolling_shutter.tracker_velocity_sigma_m_s);

  read(nh, "neighbour_depth/start_from_neighbours", &o->neighbour_depth.start_from_neighbours);
  read(nh, "neighbour_depth/start_iterations", &o->neighbour_depth.start_iterations);
  read(nh, "neighbour_depth/start_max_cost", &o->neighbour_depth.start_max_cost);
  read(nh, "neighbour_depth/geometric_refinement", &o->neighbour_depth.geometric_refinement);
  read(nh, "neighbour_depth/geometric_iterations", &o->neighbour_depth.geometric_iterations);
  read(nh, "confidence/enabled", &o->confidence.enabled);
  double min_probability = o->confidence.min_probability;
  read(nh, "confidence/min_probability", &min_probability);
  o->confidence.min_probability = static_cast<float>(min_probability);
  read(nh, "confidence/again_with_more_views", &o->confidence.again_with_more_views);
}

// Every option of an option table that is set as ~<group>/<name>; a bad
// value is reported (the default stays).
template <typename Options>
void readOptionTable(const ros::NodeHandle& nh, const std::string& group,
                     const std::vector<amhmvs::OptionField<Options>>& table, Options* options,
                     std::ostringstream* err) {
  for (const amhmvs::OptionField<Options>& option : table) {
    std::string text;
    if (!paramText(nh, group + "/" + option.name, &text)) continue;
    try {
      option.set(*options, text);
    } catch (const amhmvs::InputError& e) {
      *err << group << "/" << option.name << ": " << e.what() << "\n";
    }
  }
}

// Each group of the mapping core checked on its own: a bad group is
// reported and replaced by its defaults.
template <typename Options>
void requireValid(const char* group, Options* options, const Options& defaults, std::ostringstream* err) {
  const std::string problems = options->validate();
  if (problems.empty()) return;
  *err << group << " options invalid, using the defaults:\n" << problems;
  *options = defaults;
}

}  // namespace

amhmvs::OnlineMapperOptions MappingConfig::defaultMapperOptions() {
  amhmvs::OnlineMapperOptions options;
  options.store.max_keyframes = 50;
  options.store.max_bytes = size_t{1} << 30;
  options.sources.max_sources = 4;
  options.fusion.max_cost = 0.6f;
  return options;
}

amhmvs::KeyframePickerOptions MappingConfig::keyframePicking() const {
  amhmvs::KeyframePickerOptions options;
  options.min_translation_m = keyframe_min_translation;
  options.min_rotation_deg = keyframe_min_rotation_deg;
  options.min_turning_translation_fraction = keyframe_min_turning_translation;
  options.min_relative_sharpness = keyframe_min_relative_sharpness;
  return options;
}

int effectiveMaxImageSize(int configured, amhmvs::Backend backend) {
  if (configured != -1) return configured;
  return backend == amhmvs::Backend::kCpu ? kCpuAutoMaxImageSize : 0;
}

MappingConfig loadMappingConfig(const ros::NodeHandle& pnh, std::string* errors) {
  MappingConfig c;
  const MappingConfig defaults;
  std::ostringstream err;
  read(pnh, "input_mode", &c.input_mode);
  read(pnh, "fixed_frame", &c.fixed_frame);
  read(pnh, "view_frame", &c.view_frame);
  read(pnh, "tf_timeout", &c.tf_timeout);
  read(pnh, "queue_size", &c.queue_size);
  read(pnh, "skip_to_newest", &c.skip_to_newest);
  read(pnh, "sync_queue_size", &c.sync_queue_size);
  read(pnh, "sync_max_interval", &c.sync_max_interval);
  read(pnh, "keyframe_min_translation", &c.keyframe_min_translation);
  read(pnh, "keyframe_min_rotation_deg", &c.keyframe_min_rotation_deg);
  read(pnh, "keyframe_min_turning_translation", &c.keyframe_min_turning_translation);
  read(pnh, "keyframe_min_relative_sharpness", &c.keyframe_min_relative_sharpness);
  read(pnh, "backend", &c.backend);
  read(pnh, "max_image_size", &c.max_image_size);
  read(pnh, "publish_depth_mm", &c.publish_depth_mm);
  read(pnh, "map_publish_period", &c.map_publish_period);
  read(pnh, "diagnostics_period", &c.diagnostics_period);
  read(pnh, "silence_timeout", &c.silence_timeout);
  read(pnh, "drop_warning_window", &c.drop_warning_window);
  read(pnh, "map_directory", &c.map_directory);
  readMapperOptions(pnh, &c.mapper);

  if (c.input_mode != "pose" && c.input_mode != "odometry" && c.input_mode != "tf" && c.input_mode != "keyframe") {
    err << "input_mode '" << c.input_mode << "' is not pose, odometry, tf or keyframe; using pose\n";
    c.input_mode = defaults.input_mode;
  }
  // A bad value is reported and replaced by its default.
  auto require = [&err](bool ok, const char* problem, auto& value, const auto& fallback) {
    if (ok) return;
    err << problem << "\n";
    value = fallback;
  };
  require(c.tf_timeout >= 0, "tf_timeout must be >= 0", c.tf_timeout, defaults.tf_timeout);
  require(c.queue_size >= 1, "queue_size must be >= 1", c.queue_size, defaults.queue_size);
  require(c.sync_queue_size >= 1, "sync_queue_size must be >= 1", c.sync_queue_size,
          defaults.sync_queue_size);
  require(c.sync_max_interval >= 0, "sync_max_interval must be >= 0", c.sync_max_interval,
          defaults.sync_max_interval);
  const std::string picking = c.keyframePicking().validate();
  if (!picking.empty()) {
    err << "keyframe picking (keyframe_*): " << picking << "using the defaults for keyframe picking\n";
    c.keyframe_min_translation = defaults.keyframe_min_translation;
    c.keyframe_min_rotation_deg = defaults.keyframe_min_rotation_deg;
    c.keyframe_min_turning_translation = defaults.keyframe_min_turning_translation;
    c.keyframe_min_relative_sharpness = defaults.keyframe_min_relative_sharpness;
  }
  try {
    amhmvs::parseBackend(c.backend);
  } catch (const amhmvs::InputError& e) {
    err << "backend: " << e.what() << "; using auto\n";
    c.backend = defaults.backend;
  }
  require(c.max_image_size == -1 || c.max_image_size == 0 || c.max_image_size >= 16,
          "max_image_size must be -1 (auto), 0 (full size) or >= 16", c.max_image_size, defaults.max_image_size);
  require(c.map_publish_period > 0, "map_publish_period must be > 0", c.map_publish_period,
          defaults.map_publish_period);
  require(c.diagnostics_period > 0, "diagnostics_period must be > 0", c.diagnostics_period,
          defaults.diagnostics_period);
  require(c.silence_timeout > 0, "silence_timeout must be > 0", c.silence_timeout, defaults.silence_timeout);
  require(c.drop_warning_window > 0, "drop_warning_window must be > 0", c.drop_warning_window,
          defaults.drop_warning_window);

  requireValid("store", &c.mapper.store, defaults.mapper.store, &err);
  requireValid("sources", &c.mapper.sources, defaults.mapper.sources, &err);
  requireValid("depth_range", &c.mapper.depth_range, defaults.mapper.depth_range, &err);
  requireValid("fusion", &c.mapper.fusion, defaults.mapper.fusion, &err);
  requireValid("map", &c.mapper.map, defaults.mapper.map, &err);
  requireValid("refinement", &c.mapper.refinement, defaults.mapper.refinement, &err);
  requireValid("confidence", &c.mapper.confidence, defaults.mapper.confidence, &err);
  requireValid("neighbour_depth", &c.mapper.neighbour_depth, defaults.mapper.neighbour_depth, &err);

  // Pose refinement and estimator options: every entry of their option
  // tables, as ~pose_refinement/<name> and ~estimator/<name>.
  readOptionTable(pnh, "pose_refinement", amhmvs::poseRefinementOptionTable(), &c.mapper.pose_refinement, &err);
  requireValid("pose_refinement", &c.mapper.pose_refinement, defaults.mapper.pose_refinement, &err);
  if (c.mapper.pose_refinement.enabled && !amhmvs::PoseRefiner::available())
    err << "pose_refinement/enabled: " << amhmvs::PoseRefiner::unavailableMessage() << "; the tracker's poses are used\n";
  readOptionTable(pnh, "estimator", amhmvs::patchMatchOptionTable(), &c.estimator, &err);
  requireValid("estimator", &c.estimator, defaults.estimator, &err);
  if (errors) *errors = err.str();
  return c;
}

}  // namespace amhmvs_mapping
