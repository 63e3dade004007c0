// Fused keyframe points -> global voxel map -> PLY and PCD files.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/map_export.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// A 10 x 10 grid of fused points on the plane z = 2 of a keyframe, 0.05 m
// apart (one point per 0.02 m voxel), with distinct colours.
KeyframePoints fusedGrid() {
  KeyframePoints fused;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) {
      KeyframePoint p;
      p.position = Eigen::Vector3f(0.05f * i + 0.011f, 0.05f * j + 0.011f, 2.0f);
      p.normal = Eigen::Vector3f(0, 0, -1);
      p.rgb[0] = static_cast<uint8_t>(20 * i);
      p.rgb[1] = static_cast<uint8_t>(20 * j);
      p.rgb[2] = 7;
      p.confidence = 0.5f;
      fused.push_back(p);
    }
  }
  return fused;
}

TEST(MapExport, MapWritesPlyWithNormalsAndColourAndPcd) {
  VoxelMap map;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1, 0, 0);
  map.addKeyframe(7, pose, fusedGrid());
  ASSERT_EQ(map.voxelCount(), 100u);
  const PointCloud exported = map.exportCloud();  // the one cloud type: file writers take it as it is
  ASSERT_EQ(exported.counts.size(), 100u);
  EXPECT_EQ(exported.counts[0], 1u);
  EXPECT_TRUE(exported.validate().empty());

  test::TempDir dir;
  writeMap(dir.file("map.ply"), map);
  const PointCloud ply = readPly(dir.file("map.ply"));
  ASSERT_EQ(ply.size(), 100u);
  ASSERT_EQ(ply.normals.size(), 100u);
  ASSERT_EQ(ply.colors.size(), 100u);
  float min_x = 1e9f;
  for (size_t i = 0; i < ply.size(); ++i) {
    min_x = std::min(min_x, ply.points[i].x());
    EXPECT_NEAR(ply.points[i].z(), 2.0f, 1e-5f);          // world = camera + (1, 0, 0)
    EXPECT_NEAR(ply.normals[i].z(), -1.0f, 1e-5f);
    EXPECT_EQ(ply.colors[i][2], 7);
  }
  EXPECT_NEAR(min_x, 1.011f, 1e-5f);

  writeMap(dir.file("map.pcd"), map);
  std::ifstream pcd(dir.file("map.pcd"), std::ios::binary);
  std::string header((std::istreambuf_iterator<char>(pcd)), std::istreambuf_iterator<char>());
  EXPECT_NE(header.find("POINTS 100"), std::string::npos);
  EXPECT_NE(header.find("normal_x"), std::string::npos);
  EXPECT_THROW(writeMap(dir.file("map.xyz"), map), InputError);
}

}  // namespace
}  // namespace amhmvs
