// Every parameter of the mapping product in one table: the nodelet's ROS
// parameters (~group/name), amhmvs_map's --config / --set / --group/name
// flags, config/mapping.yaml, dynamic_reconfigure's defaults and
// docs/parameters.md all come from mappingParameterTable(), and the
// defaults from MappingParameters' constructor. The nodelet and amhmvs_map
// therefore run the same defaults; the one rule that depends on the machine
// is the image size (effectiveMaxImageSize).
//
// The node's own parameters (inputs, frames, publication) are declared here
// too, as plain data, so that the table, the yaml and the docs are one list;
// only the ROS layer reads them.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "amhmvs_mapping/core/option_field.h"
#include "amhmvs_mapping/mapping/keyframe_picker.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"

namespace amhmvs {

// The ROS node's own parameters (not used by the ROS-free pipeline).
struct NodeOptions {
  std::string input_mode = "pose";  // pose, odometry, tf, keyframe
  std::string image_transport = "raw";
  std::string fixed_frame = "world";
  std::string view_frame = "amhmvs_view";
  std::string view_up = "auto";  // view_anchor.h: auto or X,Y,Z
  double tf_timeout = 0.1;
  int sync_queue_size = 10;
  double sync_max_interval = 0.05;
  bool publish_depth_mm = false;
  double map_publish_period = 2.0;
  double diagnostics_period = 1.0;
  double silence_timeout = 5.0;
  double drop_warning_window = 10.0;
  std::string map_directory;
  std::string save_map_on_shutdown;  // a map file the nodelet writes as it shuts down; empty: none

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

struct MappingParameters {
  NodeOptions node;
  PipelineOptions pipeline;         // mapper groups, estimator/, backend, queue_size, skip_to_newest
  KeyframePickerOptions keyframes;  // keyframe_* (pose, odometry and tf input; amhmvs_map)
  // Longest processed image side: 0 = full size, -1 = auto (effectiveMaxImageSize).
  int max_image_size = -1;

  // The product's defaults: the components' own, except where online use
  // on real video needs others (set in one place, the constructor).
  MappingParameters();

  // Empty when valid; otherwise one line per problem, prefixed by the group.
  std::string validate() const;
};

using MappingParameter = OptionField<MappingParameters>;

// Every parameter, in the order of config/mapping.yaml. Names are the ROS
// parameter names: "name" at the top level, "group/name" in a group.
const std::vector<MappingParameter>& mappingParameterTable();

struct ParameterGroup {
  std::string name;  // "" for the top level
  std::string description;
};
// The groups in table order, with what each is for.
const std::vector<ParameterGroup>& mappingParameterGroups();

// The entry named `name` (its ROS name, "group/name"), or null.
const MappingParameter* findMappingParameter(const std::string& name);
// The entry whose older command-line name is `alias`, or null.
const MappingParameter* findMappingParameterByAlias(const std::string& alias);
// Sets parameter `name` from text; InputError for an unknown name (with the
// closest known one) or a bad value (with the name, the value and why).
void setMappingParameter(const std::string& name, const std::string& value, MappingParameters* parameters);
// Whether it is one of NodeOptions' (read by the ROS node only).
bool isNodeParameter(const MappingParameter& parameter);
// The known name closest to `name` (edit distance), for error messages.
std::string closestParameterName(const std::string& name);

// config/mapping.yaml and docs/parameters.md as the table writes them.
std::string mappingParametersYaml();
std::string mappingParametersMarkdown();

// The `key: value` settings of a parameter file in the layout of
// config/mapping.yaml (top-level keys, one level of groups, scalars and
// [x, y, z] lists, # comments): ("group/name", value text) in file order.
// InputError with the file and line for anything else.
std::vector<std::pair<std::string, std::string>> readParameterFile(const std::string& path);
// Every setting of such a file applied, in file order; the names set
// (InputError naming the file and the parameter for unknown names and bad values).
std::vector<std::string> applyParameterFile(const std::string& path, MappingParameters* parameters);

// The CPU takes seconds per 320 px depth map on 2 cores and minutes at full
// size: max_image_size -1 (auto) is full size (0) on the GPU and this on the CPU.
constexpr int kCpuAutoMaxImageSize = 320;
int effectiveMaxImageSize(int configured, Backend backend);
// max_image_size's range: -1 (auto), 0 (full size) or >= 16.
bool validMaxImageSize(int configured);

}  // namespace amhmvs
