// Message conversions and output builders of the mapping nodelet
// (src/ros/ros_conversions.cpp): bad input is refused with a reason, outputs
// follow REP-118 and carry no NaN points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include <sensor_msgs/point_cloud2_iterator.h>

#include "amhmvs_mapping/ros/ros_conversions.h"

using namespace amhmvs_mapping;

namespace {

sensor_msgs::Image imageMsg(const std::string& encoding, int width, int height, int channels) {
  sensor_msgs::Image msg;
  msg.encoding = encoding;
  msg.width = width;
  msg.height = height;
  msg.step = width * channels + 3;  // padded rows
  msg.data.resize(msg.step * height);
  for (size_t i = 0; i < msg.data.size(); ++i) msg.data[i] = static_cast<uint8_t>(i % 251);
  return msg;
}

geometry_msgs::Pose identityPose() {
  geometry_msgs::Pose pose;
  pose.orientation.w = 1;
  return pose;
}

sensor_msgs::CameraInfo infoMsg(int width, int height) {
  sensor_msgs::CameraInfo info;
  info.width = width;
  info.height = height;
  info.K = {100, 0, (width - 1) / 2.0, 0, 100, (height - 1) / 2.0, 0, 0, 1};
  return info;
}

}  // namespace

TEST(RosConversions, ImagesByEncodingWithPaddedRows) {
  amhmvs::ImageU8 image;
  const sensor_msgs::Image bgr = imageMsg("bgr8", 5, 4, 3);
  ASSERT_EQ(imageFromMsg(bgr, &image), "");
  ASSERT_EQ(image.channels, 3);
  EXPECT_EQ(image.at(2, 3, 0), bgr.data[3 * bgr.step + 2 * 3 + 2]);  // R from the third byte
  EXPECT_EQ(image.at(2, 3, 2), bgr.data[3 * bgr.step + 2 * 3 + 0]);
  const sensor_msgs::Image rgb = imageMsg("rgb8", 5, 4, 3);
  ASSERT_EQ(imageFromMsg(rgb, &image), "");
  EXPECT_EQ(image.at(4, 1, 1), rgb.data[1 * rgb.step + 4 * 3 + 1]);
  const sensor_msgs::Image mono = imageMsg("mono8", 5, 4, 1);
  ASSERT_EQ(imageFromMsg(mono, &image), "");
  EXPECT_EQ(image.channels, 1);
  EXPECT_EQ(image.at(3, 2), mono.data[2 * mono.step + 3]);

  EXPECT_NE(imageFromMsg(imageMsg("16UC1", 5, 4, 2), &image).find("unsupported encoding"), std::string::npos);
  EXPECT_FALSE(supportedEncoding("32FC1"));
  EXPECT_FALSE(supportedEncoding("yuv422"));
  sensor_msgs::Image truncated = rgb;
  truncated.data.resize(10);
  EXPECT_NE(imageFromMsg(truncated, &image), "");
}

TEST(RosConversions, MoreEncodingsThroughCvBridge) {
  amhmvs::ImageU8 image;
  const sensor_msgs::Image bgra = imageMsg("bgra8", 5, 4, 4);
  ASSERT_EQ(imageFromMsg(bgra, &image), "");
  ASSERT_EQ(image.channels, 3);  // alpha dropped
  EXPECT_EQ(image.at(2, 3, 0), bgra.data[3 * bgra.step + 2 * 4 + 2]);
  EXPECT_EQ(image.at(2, 3, 2), bgra.data[3 * bgra.step + 2 * 4 + 0]);
  const sensor_msgs::Image rgba = imageMsg("rgba8", 5, 4, 4);
  ASSERT_EQ(imageFromMsg(rgba, &image), "");
  EXPECT_EQ(image.at(4, 1, 1), rgba.data[1 * rgba.step + 4 * 4 + 1]);
  // mono16: 16-bit grey, scaled to 8 bits (65535 -> 255).
  sensor_msgs::Image mono16 = imageMsg("mono16", 4, 3, 2);
  EXPECT_NE(imageFromMsg(mono16, &image).find("does not match"), std::string::npos);  // odd step: not 16-bit rows
  mono16.step = 4 * 2 + 4;
  mono16.data.assign(mono16.step * 3, 0xff);
  ASSERT_EQ(imageFromMsg(mono16, &image), "");
  ASSERT_EQ(image.channels, 1);
  EXPECT_EQ(image.at(3, 2), 255);
  // A uniform Bayer mosaic debayers to the same grey in every channel.
  sensor_msgs::Image bayer = imageMsg("bayer_rggb8", 8, 6, 1);
  std::fill(bayer.data.begin(), bayer.data.end(), 90);
  ASSERT_EQ(imageFromMsg(bayer, &image), "");
  ASSERT_EQ(image.channels, 3);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(image.at(4, 3, c), 90) << c;
  // A step shorter than a row of 4-byte pixels is refused before cv_bridge reads it.
  sensor_msgs::Image short_step = bgra;
  short_step.step = 5 * 3;
  EXPECT_NE(imageFromMsg(short_step, &image).find("does not match its size"), std::string::npos);
}

TEST(RosConversions, PosesMustBeFiniteAndRigid) {
  Eigen::Isometry3d pose;
  geometry_msgs::Pose msg = identityPose();
  msg.position.x = 1.5;
  ASSERT_EQ(poseFromMsg(msg, &pose), "");
  EXPECT_DOUBLE_EQ(pose.translation().x(), 1.5);
  msg.position.y = std::nan("");
  EXPECT_NE(poseFromMsg(msg, &pose).find("non-finite"), std::string::npos);
  msg = identityPose();
  msg.orientation.w = 2;  // a scaled rotation
  EXPECT_NE(poseFromMsg(msg, &pose).find("not rigid"), std::string::npos);
  msg.orientation.w = 0;  // all-zero quaternion
  EXPECT_NE(poseFromMsg(msg, &pose), "");
}

TEST(RosConversions, CameraInfoMustMatchTheImage) {
  amhmvs::PinholeCamera camera;
  bool distorted = true;
  sensor_msgs::CameraInfo info = infoMsg(100, 80);
  ASSERT_EQ(cameraFromMsg(info, 100, 80, Eigen::Isometry3d::Identity(), &camera, &distorted), "");
  EXPECT_FALSE(distorted);
  EXPECT_DOUBLE_EQ(camera.fx, 100);
  EXPECT_NE(cameraFromMsg(info, 200, 80, Eigen::Isometry3d::Identity(), &camera).find("does not match"),
            std::string::npos);
  info.K[0] = 0;
  EXPECT_NE(cameraFromMsg(info, 100, 80, Eigen::Isometry3d::Identity(), &camera), "");
  info = infoMsg(100, 80);
  info.D = {0.1, 0, 0, 0, 0};
  ASSERT_EQ(cameraFromMsg(info, 100, 80, Eigen::Isometry3d::Identity(), &camera, &distorted), "");
  EXPECT_TRUE(distorted);
}

// REP-118's 16UC1: millimetres, rounded; 0 where invalid, non-positive or
// beyond what 16 bits hold.
TEST(RosConversions, DepthInMillimetres) {
  amhmvs::ImageF depth(6, 1, 1);
  const float metres[6] = {1.2344f, 0.0f, NAN, 65.535f, 65.6f, -2.0f};
  std::copy(metres, metres + 6, depth.data.begin());
  std_msgs::Header header;
  header.frame_id = "cam";
  const sensor_msgs::ImagePtr msg = depthImageMillimetresMsg(depth, header);
  EXPECT_EQ(msg->encoding, "16UC1");
  EXPECT_EQ(msg->header.frame_id, "cam");
  EXPECT_EQ(msg->step, 12u);
  EXPECT_FALSE(msg->is_bigendian);
  uint16_t values[6];
  ASSERT_EQ(msg->data.size(), sizeof(values));
  std::memcpy(values, msg->data.data(), sizeof(values));
  EXPECT_EQ(values[0], 1234);
  EXPECT_EQ(values[1], 0);
  EXPECT_EQ(values[2], 0);
  EXPECT_EQ(values[3], 65535);
  EXPECT_EQ(values[4], 0);
  EXPECT_EQ(values[5], 0);
}

TEST(RosConversions, DepthOutputsAndCloud) {
  amhmvs::PinholeCamera camera;
  ASSERT_EQ(cameraFromMsg(infoMsg(4, 3), 4, 3, Eigen::Isometry3d::Identity(), &camera), "");
  amhmvs::DepthMap map;
  map.depth = amhmvs::ImageF(4, 3, 1, 2.0f);
  map.normal = amhmvs::ImageF(4, 3, 3, 0.0f);
  map.cost = amhmvs::ImageF(4, 3, 1, 0.2f);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) map.normal.at(x, y, 2) = -1;
  map.depth.at(0, 0) = NAN;          // invalid
  map.cost.at(1, 0) = 1.5f;          // too costly for the cloud
  map.normal.at(2, 0, 0) = NAN;      // no normal
  std_msgs::Header header;
  header.frame_id = "cam";
  header.stamp = ros::Time(12, 5);

  const sensor_msgs::ImagePtr depth = depthImageMsg(map.depth, header);
  EXPECT_EQ(depth->encoding, "32FC1");
  EXPECT_EQ(depth->header.frame_id, "cam");
  EXPECT_EQ(depth->step, 16u);
  float values[12];
  std::memcpy(values, depth->data.data(), sizeof(values));
  EXPECT_TRUE(std::isnan(values[0]));
  EXPECT_FLOAT_EQ(values[1], 2.0f);

  const sensor_msgs::CameraInfoPtr info = cameraInfoMsg(camera, header);
  EXPECT_EQ(info->width, 4u);
  EXPECT_EQ(info->height, 3u);
  EXPECT_DOUBLE_EQ(info->P[0], 100);

  const sensor_msgs::ImagePtr confidence = confidenceImageMsg(map, header);
  std::memcpy(values, confidence->data.data(), sizeof(values));
  EXPECT_FLOAT_EQ(values[0], 0.0f);
  EXPECT_FLOAT_EQ(values[1], 0.25f);
  EXPECT_FLOAT_EQ(values[3], 0.9f);

  // The calibrated confidence as published (~confidence/enabled): the
  // probabilities as they are, clamped to [0, 1], NaN as 0.
  amhmvs::PublishedDepth published;
  published.confidence = amhmvs::ImageF(4, 3, 1, 0.5f);
  published.confidence.data[1] = 0.97f;
  published.confidence.data[2] = NAN;
  published.confidence.data[3] = 1.5f;
  const sensor_msgs::ImagePtr calibrated = confidenceImageMsg(published, header);
  EXPECT_EQ(calibrated->encoding, "32FC1");
  EXPECT_EQ(calibrated->header.frame_id, "cam");
  std::memcpy(values, calibrated->data.data(), sizeof(values));
  EXPECT_FLOAT_EQ(values[0], 0.5f);
  EXPECT_FLOAT_EQ(values[1], 0.97f);
  EXPECT_FLOAT_EQ(values[2], 0.0f);
  EXPECT_FLOAT_EQ(values[3], 1.0f);

  const sensor_msgs::ImagePtr preview = depthPreviewMsg(map.depth, header);
  ASSERT_TRUE(preview);
  EXPECT_EQ(preview->encoding, "bgr8");
  EXPECT_FALSE(depthPreviewMsg(amhmvs::ImageF(2, 2, 1, NAN), header));

  // Clouds: one point per finite entry, fields x y z rgb normal_*.
  amhmvs::KeyframePoints points(4);
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].position = Eigen::Vector3f(0.5f * i, 0, 2);
    points[i].normal = Eigen::Vector3f(0, 0, -1);
  }
  points[3].rgb[0] = 255;            // red last point
  points[1].position.y() = NAN;      // left out
  points[2].normal.x() = INFINITY;   // left out
  const sensor_msgs::PointCloud2Ptr cloud = cloudMsg(keyframeCloud(points), header);
  ASSERT_EQ(cloud->width * cloud->height, 2u);
  EXPECT_TRUE(cloud->is_dense);
  EXPECT_EQ(cloud->header.frame_id, header.frame_id);
  ASSERT_EQ(cloud->fields.size(), 7u);
  EXPECT_EQ(cloud->fields[3].name, "rgb");
  EXPECT_EQ(cloud->fields[6].name, "normal_z");
  sensor_msgs::PointCloud2ConstIterator<float> x(*cloud, "x"), z(*cloud, "z"), nz(*cloud, "normal_z");
  sensor_msgs::PointCloud2ConstIterator<uint8_t> rgb(*cloud, "rgb");
  EXPECT_FLOAT_EQ(x[0], 0.0f);
  EXPECT_FLOAT_EQ(z[0], 2.0f);
  EXPECT_FLOAT_EQ(nz[0], -1.0f);
  EXPECT_EQ(rgb[2], 0);
  ++x, ++rgb;
  EXPECT_FLOAT_EQ(x[0], 1.5f);
  EXPECT_EQ(rgb[2], 255);  // packed 0x00RRGGBB, little endian: byte 2 is red
}

TEST(RosConversions, MeshMarkerHasThreeColouredPointsPerTriangleAndNoNaN) {
  amhmvs::TriangleMesh mesh;
  mesh.vertices.points = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {NAN, 0, 1}};
  mesh.vertices.colors = {{{255, 0, 0}}, {{0, 255, 0}}, {{0, 0, 255}}, {{9, 9, 9}}};
  mesh.triangles = {{{0, 1, 2}}, {{0, 2, 3}}};  // the second has a NaN vertex
  std_msgs::Header header;
  header.frame_id = "map";
  const visualization_msgs::MarkerPtr msg = meshMarkerMsg(mesh, header);
  EXPECT_EQ(msg->header.frame_id, "map");
  EXPECT_EQ(msg->type, visualization_msgs::Marker::TRIANGLE_LIST);
  ASSERT_EQ(msg->points.size(), 3u);
  ASSERT_EQ(msg->colors.size(), 3u);
  EXPECT_EQ(msg->points[1].x, 1.0);
  EXPECT_FLOAT_EQ(msg->colors[1].g, 1.0f);
  EXPECT_FLOAT_EQ(msg->colors[1].r, 0.0f);
  EXPECT_EQ(msg->pose.orientation.w, 1.0);
  EXPECT_EQ(msg->scale.x, 1.0);
  // Without colours: one colour for the marker, none per point.
  mesh.vertices.colors.clear();
  const visualization_msgs::MarkerPtr grey = meshMarkerMsg(mesh, header);
  EXPECT_TRUE(grey->colors.empty());
  EXPECT_EQ(grey->points.size(), 3u);
  EXPECT_GT(grey->color.a, 0.0f);
}
