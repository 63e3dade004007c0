// The global voxel map into point-cloud files.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/voxel_map.h"

namespace amhmvs {

// Writes the whole map: binary PLY with normals, colour and confidence, or
// PCD, by the path's extension (.ply / .pcd). Throws InputError otherwise.
void writeMap(const std::string& path, const VoxelMap& map);

}  // namespace amhmvs
