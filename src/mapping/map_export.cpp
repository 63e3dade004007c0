#include "amhmvs_mapping/mapping/map_export.h"

namespace amhmvs {

void writeMap(const std::string& path, const VoxelMap& map) { writePointCloud(path, map.exportCloud()); }

}  // namespace amhmvs
