#include "amhmvs_mapping/ros/mapping_config.h"

#include <map>
#include <set>
#include <sstream>

#include <XmlRpcValue.h>
#include <ros/param.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"

namespace amhmvs_mapping {
namespace {

// A parameter's value as the table's text: scalars as they read, a list as
// "[a, b, c]" (map/region_min); false for other types.
bool valueText(const XmlRpc::XmlRpcValue& value, std::string* text) {
  std::ostringstream out;
  out.precision(17);
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: out << (static_cast<bool>(value) ? "true" : "false"); break;
    case XmlRpc::XmlRpcValue::TypeInt: out << static_cast<int>(value); break;
    case XmlRpc::XmlRpcValue::TypeDouble: out << static_cast<double>(value); break;
    case XmlRpc::XmlRpcValue::TypeString: out << static_cast<std::string>(value); break;
    case XmlRpc::XmlRpcValue::TypeArray: {
      out << "[";
      for (int i = 0; i < value.size(); ++i) {
        std::string item;
        XmlRpc::XmlRpcValue element = value[i];
        if (element.getType() == XmlRpc::XmlRpcValue::TypeArray || !valueText(element, &item)) return false;
        out << (i ? ", " : "") << item;
      }
      out << "]";
      break;
    }
    default: return false;
  }
  *text = out.str();
  return true;
}

// The parameters of a dictionary by name, nested ones as "group/name"
// (XmlRpcValue iterates only when not const).
void collectParameters(XmlRpc::XmlRpcValue& value, const std::string& prefix,
                       std::map<std::string, XmlRpc::XmlRpcValue>* parameters) {
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    (*parameters)[prefix] = value;
    return;
  }
  for (auto& entry : value)
    collectParameters(entry.second, prefix.empty() ? entry.first : prefix + "/" + entry.first, parameters);
}

// Parameters the nodelet's libraries read themselves under its namespace.
const std::set<std::string> kReadElsewhere = {"image_transport", "bond_disable_heartbeat_timeout"};

// Each group checked on its own: a bad group is reported and replaced by its defaults.
template <typename Options>
void requireValid(const char* group, Options* options, const Options& defaults, std::ostringstream* err) {
  const std::string problems = options->validate();
  if (problems.empty()) return;
  *err << group << " parameters invalid, using their defaults:\n" << problems;
  *options = defaults;
}

}  // namespace

LoadedConfig loadMappingConfig(const ros::NodeHandle& pnh) {
  LoadedConfig loaded;
  MappingConfig& c = loaded.config;
  const MappingConfig defaults;
  std::ostringstream err;
  // The namespace in one request: what is set, and what is set that no entry names.
  XmlRpc::XmlRpcValue all;
  std::map<std::string, XmlRpc::XmlRpcValue> given;
  if (ros::param::get(pnh.getNamespace(), all)) collectParameters(all, "", &given);
  for (const auto& [name, value] : given) {
    const amhmvs::MappingParameter* parameter = amhmvs::findMappingParameter(name);
    if (!parameter) {
      if (!kReadElsewhere.count(name))
        loaded.unknown.push_back(name + " (did you mean " + amhmvs::closestParameterName(name) + "?)");
      continue;
    }
    std::string text;
    if (!valueText(value, &text)) {
      err << name << ": not a value of this parameter's type; its default " << parameter->get(defaults)
          << " is used\n";
      continue;
    }
    try {
      parameter->set(c, text);
    } catch (const amhmvs::InputError& e) {
      err << name << " = '" << text << "': " << e.what() << "; its default " << parameter->get(defaults)
          << " is used\n";
    }
  }

  amhmvs::OnlineMapperOptions& mapper = c.pipeline.mapper;
  const amhmvs::OnlineMapperOptions& default_mapper = defaults.pipeline.mapper;
  requireValid("node", &c.node, defaults.node, &err);
  requireValid("keyframe picking (keyframe_*)", &c.keyframes, defaults.keyframes, &err);
  if (!amhmvs::validMaxImageSize(c.max_image_size)) {
    err << "max_image_size must be -1 (auto), 0 (full size) or >= 16 (got " << c.max_image_size << "); using "
        << defaults.max_image_size << "\n";
    c.max_image_size = defaults.max_image_size;
  }
  if (c.pipeline.queue_size < 1) {
    err << "queue_size must be >= 1; using " << defaults.pipeline.queue_size << "\n";
    c.pipeline.queue_size = defaults.pipeline.queue_size;
  }
  requireValid("store", &mapper.store, default_mapper.store, &err);
  requireValid("sources", &mapper.sources, default_mapper.sources, &err);
  requireValid("depth_range", &mapper.depth_range, default_mapper.depth_range, &err);
  requireValid("fusion", &mapper.fusion, default_mapper.fusion, &err);
  requireValid("map", &mapper.map, default_mapper.map, &err);
  requireValid("refinement", &mapper.refinement, default_mapper.refinement, &err);
  requireValid("confidence", &mapper.confidence, default_mapper.confidence, &err);
  requireValid("neighbour_depth", &mapper.neighbour_depth, default_mapper.neighbour_depth, &err);
  requireValid("rolling_shutter", &mapper.rolling_shutter, default_mapper.rolling_shutter, &err);
  requireValid("pose_refinement", &mapper.pose_refinement, default_mapper.pose_refinement, &err);
  if (mapper.pose_refinement.enabled && !amhmvs::PoseRefiner::available())
    err << "pose_refinement/enabled: " << amhmvs::PoseRefiner::unavailableMessage() << "; the tracker's poses are used\n";
  requireValid("estimator", &c.pipeline.estimator, defaults.pipeline.estimator, &err);
  loaded.errors = err.str();
  return loaded;
}

}  // namespace amhmvs_mapping
