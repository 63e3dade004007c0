// rviz markers of the mapping nodelet (keyframe_markers.h): frusta geometry
// and source links.
#include <gtest/gtest.h>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/ros/keyframe_markers.h"
#include "../unit/test_helpers.h"

namespace amhmvs_mapping {
namespace {

MarkerCamera cameraAt(int64_t id, double x) {
  MarkerCamera entry;
  entry.id = id;
  entry.camera = amhmvs::test::centredCamera(100, 80, 100);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().x() = x;
  amhmvs::setCameraToWorld(pose, &entry.camera);
  return entry;
}

TEST(KeyframeMarkers, FrustaAndSourceLinks) {
  std_msgs::Header header;
  header.frame_id = "world";
  MarkerCamera broken = cameraAt(7, 5);
  broken.camera.fx = 0;  // invalid: left out
  const visualization_msgs::MarkerArray array =
      keyframeMarkers({cameraAt(1, 0), cameraAt(2, 1), broken, cameraAt(3, 2)}, 3, {2, 1, 99}, 2.0, header);
  ASSERT_EQ(array.markers.size(), 2u);
  const visualization_msgs::Marker& frusta = array.markers[0];
  EXPECT_EQ(frusta.ns, "frusta");
  EXPECT_EQ(frusta.header.frame_id, "world");
  EXPECT_EQ(frusta.type, visualization_msgs::Marker::LINE_LIST);
  ASSERT_EQ(frusta.points.size(), 3u * 16);  // 8 segments per valid camera
  // First camera: apex at the origin, first base corner = pixel edge (-0.5, -0.5) at z = 2.
  EXPECT_DOUBLE_EQ(frusta.points[0].x, 0);
  EXPECT_DOUBLE_EQ(frusta.points[1].x, -50.0 / 100 * 2);
  EXPECT_DOUBLE_EQ(frusta.points[1].y, -40.0 / 100 * 2);
  EXPECT_DOUBLE_EQ(frusta.points[1].z, 2);
  const visualization_msgs::Marker& links = array.markers[1];
  EXPECT_EQ(links.ns, "source_links");
  ASSERT_EQ(links.points.size(), 4u);  // to 2 and 1; 99 is unknown
  EXPECT_DOUBLE_EQ(links.points[0].x, 2);
  EXPECT_DOUBLE_EQ(links.points[1].x, 1);
  EXPECT_DOUBLE_EQ(links.points[3].x, 0);
}

}  // namespace
}  // namespace amhmvs_mapping
