#include "amhmvs_mapping/ros/mapping_tunables.h"

#include <sstream>
#include <stdexcept>
#include <string>

namespace amhmvs_mapping {
namespace {

using Config = MappingTunablesConfig;

// Each tunable and the parameter it is (cfg/MappingTunables.cfg names the
// same pairs); the values go through the parameter table's text, so a
// fusion check that is off reads as 0 and 0 switches it off, as in the yaml.
struct Tunable {
  const char* parameter;
  int Config::*integer;
  double Config::*real;
};

const Tunable kTunables[] = {
    {"estimator/iterations", &Config::iterations, nullptr},
    {"sources/max_sources", &Config::max_sources, nullptr},
    {"keyframe_min_translation", nullptr, &Config::keyframe_min_translation},
    {"keyframe_min_rotation_deg", nullptr, &Config::keyframe_min_rotation_deg},
    {"fusion/max_reprojection_error", nullptr, &Config::max_reprojection_error},
    {"fusion/max_relative_depth_difference", nullptr, &Config::max_relative_depth_difference},
    {"fusion/max_normal_angle_deg", nullptr, &Config::max_normal_angle_deg},
    {"fusion/min_consistent_views", &Config::min_consistent_views, nullptr},
    {"fusion/max_cost", nullptr, &Config::max_cost},
    {"map/voxel_size", nullptr, &Config::voxel_size},
    {"map/min_points_per_voxel", &Config::min_points_per_voxel, nullptr},
};

const amhmvs::MappingParameter& parameterOf(const Tunable& tunable) {
  const amhmvs::MappingParameter* parameter = amhmvs::findMappingParameter(tunable.parameter);
  if (!parameter) throw std::logic_error(std::string("tunable of an unknown parameter ") + tunable.parameter);
  return *parameter;
}

}  // namespace

MappingTunablesConfig tunablesFrom(const MappingConfig& config) {
  MappingTunablesConfig t = MappingTunablesConfig::__getDefault__();
  for (const Tunable& tunable : kTunables) {
    const std::string text = parameterOf(tunable).get(config);
    if (tunable.integer) t.*tunable.integer = std::stoi(text);
    else t.*tunable.real = std::stod(text);
  }
  return t;
}

void applyTunables(const MappingTunablesConfig& t, MappingConfig* config) {
  for (const Tunable& tunable : kTunables) {
    std::ostringstream text;
    text.precision(17);
    if (tunable.integer) text << t.*tunable.integer;
    else text << t.*tunable.real;
    parameterOf(tunable).set(*config, text.str());
  }
}

}  // namespace amhmvs_mapping
