// The surface map against Open3D's TSDF integration and marching cubes
// (ScalableTSDFVolume, Debian's libopen3d-dev) on the same depth images: a
// sphere before a wall and a floor, seen from six views. Open3D stores the
// distance along the ray and puts voxel centres half a voxel off ours, so the
// two fields differ; their zero levels (the meshes) must agree with each
// other and with the true surface.
#include <gtest/gtest.h>

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "amhmvs_mapping/mapping/tsdf_map.h"
#include "mapping/tsdf_scenes.h"

namespace amhmvs {
namespace {

struct SphereBeforeAWall {
  std::vector<test::Sphere> spheres{{{0.0, 0.3, 0.45}, 0.3}};
  // The wall y = 1.007 and the floor z = 0.013: on neither our voxel centres
  // nor Open3D's (a plane through a layer of centres gives a ragged mesh of
  // slivers where the distance's sign there is decided by rounding).
  std::vector<test::Plane> planes{{{0, -1, 0}, -1.007}, {{0, 0, 1}, 0.013}};
  std::vector<PinholeCamera> cameras;
  SphereBeforeAWall() {
    for (double x : {-0.7, 0.0, 0.7})
      for (double z : {0.5, 1.1}) cameras.push_back(test::lookAt({x, -1.6, z}, {0.0, 0.4, 0.4}, 320, 240));
  }
  // Distance from p to the nearest surface that is part of the scene.
  double distanceToSurface(const Eigen::Vector3d& p) const {
    double nearest = std::abs((p - spheres[0].centre).norm() - spheres[0].radius);
    for (const test::Plane& plane : planes) nearest = std::min(nearest, std::abs(plane.normal.dot(p) - plane.offset));
    return nearest;
  }
};

open3d::geometry::RGBDImage open3dImage(const SurfaceDepth& depth) {
  open3d::geometry::RGBDImage image;
  image.depth_.Prepare(depth.camera.width, depth.camera.height, 1, 4);
  float* pixels = image.depth_.PointerAs<float>();
  for (size_t i = 0; i < depth.depth.data.size(); ++i)
    pixels[i] = std::isfinite(depth.depth.data[i]) ? depth.depth.data[i] : 0.0f;  // Open3D: 0 = none
  image.color_.Prepare(depth.camera.width, depth.camera.height, 3, 1);  // unused (no colour)
  return image;
}

std::shared_ptr<open3d::geometry::TriangleMesh> open3dMesh(const SphereBeforeAWall& scene, const TsdfMapOptions& options) {
  open3d::pipelines::integration::ScalableTSDFVolume volume(
      options.voxel_size, options.band_voxels * options.voxel_size,
      open3d::pipelines::integration::TSDFVolumeColorType::NoColor);
  for (const PinholeCamera& camera : scene.cameras) {
    const SurfaceDepth depth = test::sceneDepth(camera, scene.spheres, scene.planes);
    const open3d::camera::PinholeCameraIntrinsic intrinsic(camera.width, camera.height, camera.fx, camera.fy,
                                                          camera.cx, camera.cy);
    volume.Integrate(open3dImage(depth), intrinsic, cameraToWorld(camera).inverse().matrix());
  }
  return volume.ExtractTriangleMesh();
}

double area(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles) {
  double sum = 0;
  for (const Eigen::Vector3i& t : triangles)
    sum += 0.5 * (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).norm();
  return sum;
}

// Share of `points` within `tolerance` of the surface `mesh` (densely sampled;
// Open3D's sampler is not const).
double shareWithin(const std::vector<Eigen::Vector3d>& points, open3d::geometry::TriangleMesh& mesh,
                   double tolerance) {
  // About one sample per (tolerance / 3)^2: the sampling adds well under the tolerance.
  const double spacing = tolerance / 3;
  const size_t samples = static_cast<size_t>(mesh.GetSurfaceArea() / (spacing * spacing));
  const std::shared_ptr<open3d::geometry::PointCloud> surface = mesh.SamplePointsUniformly(samples);
  const open3d::geometry::KDTreeFlann tree(*surface);
  size_t within = 0;
  std::vector<int> index;
  std::vector<double> squared;
  for (const Eigen::Vector3d& p : points) {
    tree.SearchKNN(p, 1, index, squared);
    within += !squared.empty() && squared[0] <= tolerance * tolerance;
  }
  return points.empty() ? 0 : static_cast<double>(within) / points.size();
}

TEST(TsdfAgainstOpen3d, TheSameDepthGivesTheSameSurface) {
  const SphereBeforeAWall scene;
  TsdfMapOptions options;  // the shipped voxel size and band
  options.min_weight = 0.5;  // Open3D meshes every voxel that one view saw
  TsdfMap ours(options);
  for (size_t k = 0; k < scene.cameras.size(); ++k)
    ours.addKeyframe(static_cast<int64_t>(k), cameraToWorld(scene.cameras[k]),
                     test::sceneDepth(scene.cameras[k], scene.spheres, scene.planes));
  const TriangleMesh mesh = ours.mesh();
  open3d::geometry::TriangleMesh ours_open3d;
  for (const Eigen::Vector3f& p : mesh.vertices.points) ours_open3d.vertices_.push_back(p.cast<double>());
  for (const auto& t : mesh.triangles) ours_open3d.triangles_.emplace_back(t[0], t[1], t[2]);
  const std::shared_ptr<open3d::geometry::TriangleMesh> theirs = open3dMesh(scene, options);
  ASSERT_GT(ours_open3d.triangles_.size(), 10000u);
  ASSERT_GT(theirs->triangles_.size(), 10000u);

  const double ours_area = area(ours_open3d.vertices_, ours_open3d.triangles_);
  const double their_area = area(theirs->vertices_, theirs->triangles_);
  const auto shareOnTruth = [&](const std::vector<Eigen::Vector3d>& vertices, double tolerance) {
    size_t near = 0;
    for (const Eigen::Vector3d& p : vertices) near += scene.distanceToSurface(p) <= tolerance;
    return static_cast<double>(near) / vertices.size();
  };
  std::printf("ours: %zu triangles, %.3f m^2; Open3D: %zu triangles, %.3f m^2\n", ours_open3d.triangles_.size(),
              ours_area, theirs->triangles_.size(), their_area);
  // Measured (0.16.1): 77658 / 79148 triangles, 15.203 / 15.089 m^2; within
  // a quarter voxel of the other mesh 95.7 / 97.3 %, within a voxel 99.8 /
  // 99.9 %; both 99.3 % within a quarter voxel of the true surface. What is
  // farther apart lies at the edges of the seen region, where one mesh
  // reaches a little further (those vertices are on the true surface).
  EXPECT_NEAR(static_cast<double>(ours_open3d.triangles_.size()), static_cast<double>(theirs->triangles_.size()),
              0.05 * theirs->triangles_.size());
  EXPECT_NEAR(ours_area, their_area, 0.02 * their_area);
  struct Tolerance {
    double voxels, min_share;
  };
  for (const Tolerance& t : {Tolerance{0.25, 0.94}, Tolerance{1.0, 0.995}}) {
    const double tolerance = t.voxels * options.voxel_size;
    const double ours_on_theirs = shareWithin(ours_open3d.vertices_, *theirs, tolerance);
    const double theirs_on_ours = shareWithin(theirs->vertices_, ours_open3d, tolerance);
    std::printf("within %.1f mm: %.2f %% of ours on Open3D's, %.2f %% of Open3D's on ours\n", 1000 * tolerance,
                100 * ours_on_theirs, 100 * theirs_on_ours);
    EXPECT_GT(ours_on_theirs, t.min_share);
    EXPECT_GT(theirs_on_ours, t.min_share);
  }
  const double tolerance = 0.25 * options.voxel_size;
  const double ours_true = shareOnTruth(ours_open3d.vertices_, tolerance);
  const double theirs_true = shareOnTruth(theirs->vertices_, tolerance);
  std::printf("within %.1f mm of the true surface: ours %.2f %%, Open3D's %.2f %%\n", 1000 * tolerance, 100 * ours_true,
              100 * theirs_true);
  EXPECT_GT(ours_true, 0.99);
  EXPECT_GT(theirs_true, 0.99);  // the comparison itself is sound
}

}  // namespace
}  // namespace amhmvs
