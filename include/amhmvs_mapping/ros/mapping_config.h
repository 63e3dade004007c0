// Parameters of the mapping nodelet: every one is an entry of the mapping
// parameter table (mapping/mapping_parameters.h), read from the nodelet's
// private namespace as ~name and ~group/name, with config/mapping.yaml (made
// from the same table) as the documented defaults.
#pragma once

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "amhmvs_mapping/mapping/mapping_parameters.h"

namespace amhmvs_mapping {

using MappingConfig = amhmvs::MappingParameters;

struct LoadedConfig {
  MappingConfig config;
  std::string errors;                 // bad values (one line each); their defaults are used instead
  std::vector<std::string> unknown;   // parameters under the namespace that no table entry names, with a hint
};

// Reads every table entry that is set under `pnh` (unset ones keep their
// defaults). A value of the wrong type or out of range is reported in
// `errors` with its name and value and replaced by its default (a whole
// group when its validate() fails); names under `pnh` that the table lacks
// are listed in `unknown`, each with the closest known name.
LoadedConfig loadMappingConfig(const ros::NodeHandle& pnh);

}  // namespace amhmvs_mapping
