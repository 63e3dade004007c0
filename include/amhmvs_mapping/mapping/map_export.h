// Glue between fusion, the global voxel map and point-cloud files: fused
// points of a keyframe into the map's point type, and the map into PLY/PCD.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/voxel_map.h"

namespace amhmvs {

// The fused points of one keyframe (its camera frame) as map input.
KeyframePoints toKeyframePoints(const std::vector<FusedPoint>& fused);

// The map's averaged points (world frame) as a cloud for the file writers.
PointCloud toPointCloud(const MapCloud& map_cloud);

// A keyframe's points (its camera frame) as a world-frame cloud.
PointCloud keyframeWorldCloud(const KeyframePoints& points, const Eigen::Isometry3d& camera_to_world);

// Writes the whole map: binary PLY with normals, colour and confidence, or
// PCD, by the path's extension (.ply / .pcd). Throws InputError otherwise.
void writeMap(const std::string& path, const VoxelMap& map);

}  // namespace amhmvs
