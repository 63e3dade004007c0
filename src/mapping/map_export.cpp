#include "amhmvs_mapping/mapping/map_export.h"

namespace amhmvs {

KeyframePoints toKeyframePoints(const std::vector<FusedPoint>& fused) {
  KeyframePoints points(fused.size());
  for (size_t i = 0; i < fused.size(); ++i) {
    points[i].position = fused[i].position;
    points[i].normal = fused[i].normal;
    points[i].rgb[0] = fused[i].r;
    points[i].rgb[1] = fused[i].g;
    points[i].rgb[2] = fused[i].b;
    points[i].confidence = fused[i].confidence;
  }
  return points;
}

PointCloud toPointCloud(const MapCloud& map_cloud) {
  PointCloud cloud;
  cloud.points = map_cloud.positions;
  cloud.normals = map_cloud.normals;
  cloud.confidence = map_cloud.confidences;
  cloud.colors.reserve(map_cloud.colors.size());
  for (const auto& c : map_cloud.colors) cloud.colors.push_back({c[0], c[1], c[2]});
  return cloud;
}

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

void writeMap(const std::string& path, const VoxelMap& map) {
  writePointCloud(path, toPointCloud(map.exportCloud()));
}

}  // namespace amhmvs
