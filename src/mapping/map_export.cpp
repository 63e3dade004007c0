#include "amhmvs_mapping/mapping/map_export.h"

namespace amhmvs {

PointCloud keyframeWorldCloud(const KeyframePoints& points, const Eigen::Isometry3d& camera_to_world) {
  PointCloud cloud;
  const Eigen::Matrix3f rotation = camera_to_world.linear().cast<float>();
  const Eigen::Vector3f translation = camera_to_world.translation().cast<float>();
  for (const KeyframePoint& point : points) {
    cloud.points.push_back(rotation * point.position + translation);
    cloud.normals.push_back(rotation * point.normal);
    cloud.colors.push_back({point.rgb[0], point.rgb[1], point.rgb[2]});
    cloud.confidence.push_back(point.confidence);
  }
  return cloud;
}

void writeMap(const std::string& path, const VoxelMap& map) { writePointCloud(path, map.exportCloud()); }

}  // namespace amhmvs
