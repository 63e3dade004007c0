// The runtime tunables of the mapping nodelet (cfg/MappingTunables.cfg,
// dynamic_reconfigure) to and from its MappingConfig.
#pragma once

#include "amhmvs_mapping/MappingTunablesConfig.h"
#include "amhmvs_mapping/ros/mapping_config.h"

namespace amhmvs_mapping {

// The tunables' current values (fusion checks that are off become 0).
MappingTunablesConfig tunablesFrom(const MappingConfig& config);
// Sets the tunables in `config` (0 switches a fusion check off). The caller
// validates the result; a value the parameter's type cannot hold throws
// InputError (dynamic_reconfigure's ranges keep them inside).
void applyTunables(const MappingTunablesConfig& tunables, MappingConfig* config);

}  // namespace amhmvs_mapping
