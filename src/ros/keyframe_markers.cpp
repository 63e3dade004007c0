#include "amhmvs_mapping/ros/keyframe_markers.h"

#include <array>

#include <tf2_eigen/tf2_eigen.h>

#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs_mapping {
namespace {

visualization_msgs::Marker lineList(const std::string& ns, const std_msgs::Header& header, float r, float g,
                                    float b) {
  visualization_msgs::Marker marker;
  marker.header = header;
  marker.ns = ns;
  marker.id = 0;
  marker.type = visualization_msgs::Marker::LINE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1;
  marker.scale.x = 0.02;  // line width, metres
  marker.color.r = r;
  marker.color.g = g;
  marker.color.b = b;
  marker.color.a = 1;
  return marker;
}

void addSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, visualization_msgs::Marker* marker) {
  marker->points.push_back(tf2::toMsg(a));
  marker->points.push_back(tf2::toMsg(b));
}

}  // namespace

visualization_msgs::MarkerArray keyframeMarkers(const std::vector<MarkerCamera>& cameras, int64_t newest_id,
                                                const std::vector<int64_t>& source_ids, double frustum_depth,
                                                const std_msgs::Header& header) {
  visualization_msgs::Marker frusta = lineList("frusta", header, 0.9f, 0.6f, 0.1f);
  visualization_msgs::Marker links = lineList("source_links", header, 0.1f, 0.9f, 0.2f);
  const MarkerCamera* newest = nullptr;
  for (const MarkerCamera& entry : cameras) {
    const amhmvs::PinholeCamera& c = entry.camera;
    if (!c.validate().empty()) continue;
    if (entry.id == newest_id) newest = &entry;
    const Eigen::Isometry3d pose = amhmvs::cameraToWorld(c);
    const Eigen::Vector3d apex = pose.translation();
    // Image corners (pixel edges) at z-depth frustum_depth.
    const std::array<Eigen::Vector2d, 4> corners = {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(c.width - 0.5, -0.5),
                                                    Eigen::Vector2d(c.width - 0.5, c.height - 0.5),
                                                    Eigen::Vector2d(-0.5, c.height - 0.5)};
    std::array<Eigen::Vector3d, 4> base;
    for (size_t k = 0; k < corners.size(); ++k)
      base[k] = pose * Eigen::Vector3d((corners[k].x() - c.cx) / c.fx * frustum_depth,
                                       (corners[k].y() - c.cy) / c.fy * frustum_depth, frustum_depth);
    for (size_t k = 0; k < base.size(); ++k) {
      addSegment(apex, base[k], &frusta);
      addSegment(base[k], base[(k + 1) % base.size()], &frusta);
    }
  }
  if (newest) {
    const Eigen::Vector3d from = amhmvs::cameraToWorld(newest->camera).translation();
    for (int64_t source : source_ids)
      for (const MarkerCamera& entry : cameras)
        if (entry.id == source && entry.camera.validate().empty())
          addSegment(from, amhmvs::cameraToWorld(entry.camera).translation(), &links);
  }
  visualization_msgs::MarkerArray array;
  array.markers.push_back(frusta);
  array.markers.push_back(links);
  return array;
}

}  // namespace amhmvs_mapping
