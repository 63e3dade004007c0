// The global voxel map and keyframe points into point-cloud files.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/voxel_map.h"

namespace amhmvs {

// A keyframe's points (its camera frame) as a world-frame cloud.
PointCloud keyframeWorldCloud(const KeyframePoints& points, const Eigen::Isometry3d& camera_to_world);

// Writes the whole map: binary PLY with normals, colour and confidence, or
// PCD, by the path's extension (.ply / .pcd). Throws InputError otherwise.
void writeMap(const std::string& path, const VoxelMap& map);

}  // namespace amhmvs
