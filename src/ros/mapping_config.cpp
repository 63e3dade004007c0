#include "amhmvs_mapping/ros/mapping_config.h"

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

}  // namespace

MappingConfig loadMappingConfig(const ros::NodeHandle& pnh, std::string* errors) {
  MappingConfig c;
  const MappingConfig defaults;
  std::ostringstream err;
  pnh.param("input_mode", c.input_mode, c.input_mode);
  pnh.param("fixed_frame", c.fixed_frame, c.fixed_frame);
  pnh.param("tf_timeout", c.tf_timeout, c.tf_timeout);
  pnh.param("queue_size", c.queue_size, c.queue_size);
  pnh.param("sync_queue_size", c.sync_queue_size, c.sync_queue_size);
  pnh.param("sync_max_interval", c.sync_max_interval, c.sync_max_interval);
  pnh.param("keyframe_min_translation", c.keyframe_min_translation, c.keyframe_min_translation);
  pnh.param("keyframe_min_rotation_deg", c.keyframe_min_rotation_deg, c.keyframe_min_rotation_deg);
  pnh.param("max_keyframes", c.max_keyframes, c.max_keyframes);
  pnh.param("num_sources", c.sources.num_sources, c.sources.num_sources);
  pnh.param("min_baseline", c.sources.min_baseline, c.sources.min_baseline);
  pnh.param("max_baseline", c.sources.max_baseline, c.sources.max_baseline);
  pnh.param("max_source_angle_deg", c.sources.max_angle_deg, c.sources.max_angle_deg);
  pnh.param("min_depth", c.min_depth, c.min_depth);
  pnh.param("max_depth", c.max_depth, c.max_depth);
  pnh.param("backend", c.backend, c.backend);
  pnh.param("max_image_size", c.max_image_size, c.max_image_size);
  pnh.param("cloud_max_cost", c.cloud_max_cost, c.cloud_max_cost);
  pnh.param("diagnostics_period", c.diagnostics_period, c.diagnostics_period);

  if (c.input_mode != "pose" && c.input_mode != "tf" && c.input_mode != "keyframe") {
    err << "input_mode '" << c.input_mode << "' is not pose, tf or keyframe; using pose\n";
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
  if (!(c.keyframe_min_translation >= 0) || !(c.keyframe_min_rotation_deg >= 0)) {
    err << "keyframe_min_translation and keyframe_min_rotation_deg must be >= 0\n";
    c.keyframe_min_translation = defaults.keyframe_min_translation;
    c.keyframe_min_rotation_deg = defaults.keyframe_min_rotation_deg;
  }
  require(c.max_keyframes >= 1, "max_keyframes must be >= 1", c.max_keyframes,
          defaults.max_keyframes);
  const std::string source_problems = c.sources.validate();
  if (!source_problems.empty()) { err << source_problems; c.sources = defaults.sources; }
  if (!(c.min_depth > 0 && c.max_depth > c.min_depth && std::isfinite(c.max_depth))) {
    err << "need 0 < min_depth < max_depth (got " << c.min_depth << ", " << c.max_depth << ")\n";
    c.min_depth = defaults.min_depth;
    c.max_depth = defaults.max_depth;
  }
  try {
    amhmvs::parseBackend(c.backend);
  } catch (const amhmvs::InputError& e) {
    err << "backend: " << e.what() << "; using auto\n";
    c.backend = defaults.backend;
  }
  require(c.max_image_size == 0 || c.max_image_size >= 16,
          "max_image_size must be 0 (off) or >= 16", c.max_image_size, defaults.max_image_size);
  require(c.cloud_max_cost > 0, "cloud_max_cost must be > 0", c.cloud_max_cost,
          defaults.cloud_max_cost);
  require(c.diagnostics_period > 0, "diagnostics_period must be > 0", c.diagnostics_period,
          defaults.diagnostics_period);

  // Estimator options: every entry of the option table, as ~estimator/<name>.
  for (const amhmvs::OptionInfo& option : amhmvs::patchMatchOptionTable()) {
    std::string text;
    if (!paramText(pnh, "estimator/" + option.name, &text)) continue;
    try {
      option.set(c.estimator, text);
    } catch (const amhmvs::InputError& e) {
      err << "estimator/" << option.name << ": " << e.what() << "\n";
    }
  }
  const std::string option_problems = c.estimator.validate();
  if (!option_problems.empty()) {
    err << "estimator options invalid, using the defaults:\n" << option_problems;
    c.estimator = amhmvs::PatchMatchOptions();
  }
  if (errors) *errors = err.str();
  return c;
}

}  // namespace amhmvs_mapping
