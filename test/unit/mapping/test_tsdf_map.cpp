// The surface map: marching cubes' derived table (closed, consistently
// oriented surfaces on random fields), the TSDF against the exact distance
// of planes and spheres, exact removal and re-posing, the incremental mesh
// against one extracted from scratch, the memory bound and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/marching_cubes.h"
#include "amhmvs_mapping/mapping/tsdf_map.h"
#include "mapping/tsdf_scenes.h"

namespace amhmvs {
namespace {

// A grid of values meshed cell by cell with the case table (no TSDF).
TriangleMesh meshGrid(const std::vector<float>& values, int n) {
  TriangleMesh mesh;
  std::map<std::array<int, 4>, uint32_t> vertex_of_edge;  // (start corner, axis)
  const auto at = [&](int x, int y, int z) { return values[x + n * (y + n * z)]; };
  for (int z = 0; z + 1 < n; ++z)
    for (int y = 0; y + 1 < n; ++y)
      for (int x = 0; x + 1 < n; ++x) {
        float v[8];
        int index = 0;
        for (int c = 0; c < 8; ++c) {
          v[c] = at(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1));
          index |= (v[c] < 0) << c;
        }
        const CellCase& cell = cellCase(index);
        for (int t = 0; t < cell.triangle_count; ++t) {
          std::array<uint32_t, 3> triangle;
          for (int k = 0; k < 3; ++k) {
            const CellEdge& edge = cellEdge(cell.triangles[t][k]);
            const int c0 = edge.corner[0];
            const std::array<int, 4> key = {x + (c0 & 1), y + ((c0 >> 1) & 1), z + ((c0 >> 2) & 1), edge.axis};
            auto found = vertex_of_edge.find(key);
            if (found == vertex_of_edge.end()) {
              Eigen::Vector3f p(key[0], key[1], key[2]);
              p[edge.axis] += crossingFraction(v[c0], v[edge.corner[1]]);
              found = vertex_of_edge.emplace(key, static_cast<uint32_t>(mesh.vertices.size())).first;
              mesh.vertices.points.push_back(p);
            }
            triangle[k] = found->second;
          }
          mesh.triangles.push_back(triangle);
        }
      }
  return mesh;
}

// Each directed edge once, its reverse once: a closed, consistently oriented surface.
::testing::AssertionResult closedAndOriented(const TriangleMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) return ::testing::AssertionFailure() << "edge used " << count << " times the same way";
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1)
      return ::testing::AssertionFailure() << "edge " << edge.first << "-" << edge.second << " is a border";
  }
  return ::testing::AssertionSuccess();
}

TEST(MarchingCubes, RandomFieldsGiveClosedConsistentlyOrientedSurfaces) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(-1, 1);
  constexpr int n = 7;
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<float> values(n * n * n);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const bool border = x == 0 || y == 0 || z == 0 || x == n - 1 || y == n - 1 || z == n - 1;
          float v = value(random);
          if (std::abs(v) < 1e-3f) v = 0.5f;
          values[x + n * (y + n * z)] = border ? 1.0f : v;  // positive all round: every surface closes
        }
    const TriangleMesh mesh = meshGrid(values, n);
    ASSERT_TRUE(closedAndOriented(mesh)) << "trial " << trial;
  }
  // All 256 cases occur in such fields; check that each case's crossings are exactly its sign changes.
  for (int index = 1; index < 255; ++index) {
    bool crossed[kCellEdges] = {}, used[kCellEdges] = {};
    for (int e = 0; e < kCellEdges; ++e) {
      const CellEdge& edge = cellEdge(e);
      crossed[e] = ((index >> edge.corner[0]) & 1) != ((index >> edge.corner[1]) & 1);
    }
    const CellCase& cell = cellCase(index);
    EXPECT_GE(cell.triangle_count, 1);
    for (int t = 0; t < cell.triangle_count; ++t)
      for (int k = 0; k < 3; ++k) used[cell.triangles[t][k]] = true;
    for (int e = 0; e < kCellEdges; ++e) EXPECT_EQ(crossed[e], used[e]) << "case " << index << " edge " << e;
  }
}

TEST(MarchingCubes, SphereIsClosedOnTheSurfaceFacingOutwards) {
  constexpr int n = 24;
  const Eigen::Vector3f centre(11.3f, 11.7f, 12.1f);
  const float radius = 7.4f;
  std::vector<float> values(n * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) values[x + n * (y + n * z)] = (Eigen::Vector3f(x, y, z) - centre).norm() - radius;
  const TriangleMesh mesh = meshGrid(values, n);
  ASSERT_TRUE(closedAndOriented(mesh));
  // Euler characteristic 2: one sphere.
  const long edges = 3 * static_cast<long>(mesh.triangles.size()) / 2;
  EXPECT_EQ(static_cast<long>(mesh.vertices.size()) - edges + static_cast<long>(mesh.triangles.size()), 2);
  double area = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f& a = mesh.vertices.points[t[0]];
    const Eigen::Vector3f face = (mesh.vertices.points[t[1]] - a).cross(mesh.vertices.points[t[2]] - a);
    EXPECT_GT(face.dot(a - centre), 0) << "a triangle faces inwards";
    area += 0.5 * face.norm();
  }
  EXPECT_NEAR(area, 4 * M_PI * radius * radius, 0.02 * 4 * M_PI * radius * radius);
  for (const Eigen::Vector3f& p : mesh.vertices.points) EXPECT_NEAR((p - centre).norm(), radius, 0.05);
}

using test::lookAt;
using test::sphereDepth;

Eigen::Isometry3d poseOf(const PinholeCamera& camera) { return cameraToWorld(camera); }

// The defaults, with a surface wherever one view saw it.
TsdfMapOptions oneViewOptions() {
  TsdfMapOptions options;
  options.min_weight = 0.2;
  return options;
}

TEST(TsdfMap, FrontalPlaneGivesTheExactTruncatedDistanceAndAFlatMesh) {
  TsdfMapOptions options = oneViewOptions();
  options.voxel_size = 0.02;
  TsdfMap map(options);
  const PinholeCamera camera = lookAt({0.01, 0.013, 0}, {0.01, 0.013, 1});  // along world +z, off the voxel grid
  SurfaceDepth depth;
  depth.camera = camera;
  depth.depth = ImageF(camera.width, camera.height, 1, 1.503f);
  map.addKeyframe(1, poseOf(camera), depth);
  map.updateMesh();
  const float band = static_cast<float>(options.band_voxels * options.voxel_size);
  size_t checked = 0;
  // Every voxel of every block: where observed, the distance equals the plane's.
  const Eigen::Isometry3d world_to_camera = poseOf(camera).inverse();
  for (int x = -40; x < 40; ++x)
    for (int y = -40; y < 40; ++y)
      for (int z = 60; z < 90; ++z) {
        const TsdfVoxel* voxel = map.voxel({x, y, z});
        if (!voxel || voxel->weight <= 0) continue;
        const Eigen::Vector3d p = world_to_camera * map.voxelCentre({x, y, z});
        const float expected = std::min(1.0f, static_cast<float>((1.503 - p.z()) / band));
        ASSERT_NEAR(voxel->distance(), expected, 1e-4) << x << " " << y << " " << z;
        ++checked;
      }
  EXPECT_GT(checked, 1000u);
  const TriangleMesh mesh = map.mesh();
  ASSERT_FALSE(mesh.empty());
  const Eigen::Vector3d forward = camera.viewingDirection();
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d p = world_to_camera * mesh.vertices.points[v].cast<double>();
    ASSERT_NEAR(p.z(), 1.503, 1e-4);
    EXPECT_LT(mesh.vertices.normals[v].cast<double>().dot(forward), -0.99);  // towards the camera
  }
  EXPECT_EQ(mesh.validate(), "");
}

struct SphereScene {
  Eigen::Vector3d centre{0.3, -0.2, 1.1};
  double radius = 0.5;
  std::vector<PinholeCamera> cameras;
  SphereScene() {
    for (int k = 0; k < 8; ++k) {
      const double a = 2 * M_PI * k / 8;
      cameras.push_back(
          lookAt(centre + Eigen::Vector3d(2 * std::cos(a), 2 * std::sin(a), 1.2 * (k % 3 - 1)), centre, 320, 240));
    }
  }
  SurfaceDepth depth(int k) const { return sphereDepth(cameras[k], centre, radius); }
};

TEST(TsdfMap, SphereFromEightViewsIsMeshedOnItsSurfaceAndClosed) {
  const SphereScene scene;
  TsdfMapOptions options = oneViewOptions();
  options.voxel_size = 0.02;
  TsdfMap map(options);
  for (size_t k = 0; k < scene.cameras.size(); ++k) map.addKeyframe(k, poseOf(scene.cameras[k]), scene.depth(k));
  map.updateMesh();
  const TriangleMesh mesh = map.mesh();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  size_t near_surface = 0;
  for (const Eigen::Vector3f& p : mesh.vertices.points)
    near_surface += std::abs((p.cast<double>() - scene.centre).norm() - scene.radius) < 0.5 * options.voxel_size;
  EXPECT_GT(near_surface, 0.98 * mesh.vertices.size());
  // The area of a sphere: every part is seen by some view.
  double area = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f& a = mesh.vertices.points[t[0]];
    area += 0.5 * (mesh.vertices.points[t[1]] - a).cross(mesh.vertices.points[t[2]] - a).norm();
  }
  const double expected = 4 * M_PI * scene.radius * scene.radius;
  EXPECT_NEAR(area, expected, 0.05 * expected);
  // Each vertex once in the cloud, close to the mesh's vertex count (borders shared between blocks).
  const PointCloud cloud = map.surfaceCloud();
  EXPECT_EQ(cloud.validate(), "");
  // Positions to 0.01 mm (two blocks round the same vertex differently).
  const auto key = [](const Eigen::Vector3f& p) {
    return std::array<long, 3>{std::lround(p.x() * 1e5), std::lround(p.y() * 1e5), std::lround(p.z() * 1e5)};
  };
  std::set<std::array<long, 3>> distinct;
  for (const Eigen::Vector3f& p : cloud.points) distinct.insert(key(p));
  // Each edge's vertex once; edges that meet at a voxel whose distance is exactly 0 put theirs on it.
  EXPECT_GE(distinct.size(), cloud.size() - cloud.size() / 1000);
  // The mesh repeats the vertices on block borders; the cloud has nearly all of them once.
  std::set<std::array<long, 3>> mesh_distinct;
  for (const Eigen::Vector3f& p : mesh.vertices.points) mesh_distinct.insert(key(p));
  size_t in_cloud = 0;
  for (const auto& p : mesh_distinct) in_cloud += distinct.count(p);
  EXPECT_EQ(in_cloud, mesh_distinct.size());
}

// Bit-for-bit up to rounding: every voxel of `a` in `b` with the same values.
void expectSameVoxels(const TsdfMap& a, const TsdfMap& b, double tolerance) {
  ASSERT_EQ(a.blockCount(), b.blockCount());
  size_t compared = 0;
  for (int x = -60; x < 60; ++x)
    for (int y = -60; y < 60; ++y)
      for (int z = -10; z < 110; ++z) {
        const TsdfVoxel* va = a.voxel({x, y, z});
        const TsdfVoxel* vb = b.voxel({x, y, z});
        ASSERT_EQ(va == nullptr, vb == nullptr);
        if (!va) continue;
        ASSERT_NEAR(va->weight, vb->weight, tolerance);
        ASSERT_NEAR(va->distance_sum, vb->distance_sum, tolerance);
        ++compared;
      }
  EXPECT_GT(compared, 0u);
}

TEST(TsdfMap, RemovalAndReposingAreExactAndTheIncrementalMeshMatchesAFreshOne) {
  const SphereScene scene;
  TsdfMap incremental(oneViewOptions());
  for (int k = 0; k < 4; ++k) {
    incremental.addKeyframe(k, poseOf(scene.cameras[k]), scene.depth(k));
    incremental.updateMesh();
  }
  // Keyframe 1 re-posed (a loop closure moves it 3 cm), keyframe 0 removed.
  Eigen::Isometry3d moved = poseOf(scene.cameras[1]);
  moved.translation() += Eigen::Vector3d(0.03, 0, 0);
  incremental.updatePose(1, moved);
  incremental.removeKeyframe(0);
  const size_t visited = incremental.updateMesh();

  TsdfMap fresh(oneViewOptions());
  fresh.addKeyframe(2, poseOf(scene.cameras[2]), scene.depth(2));
  fresh.addKeyframe(3, poseOf(scene.cameras[3]), scene.depth(3));
  fresh.addKeyframe(1, moved, scene.depth(1));
  fresh.updateMesh();
  expectSameVoxels(incremental, fresh, 1e-9);
  const TriangleMesh a = incremental.mesh(), b = fresh.mesh();
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (size_t v = 0; v < a.vertices.size(); ++v) ASSERT_LT((a.vertices.points[v] - b.vertices.points[v]).norm(), 1e-5);
  EXPECT_LE(visited, 8 * incremental.blockCount());

  // Only what changed is extracted again: a keyframe that sees a small patch
  // leaves most blocks alone.
  SurfaceDepth patch = scene.depth(6);
  for (int y = 0; y < patch.camera.height; ++y)
    for (int x = 0; x < patch.camera.width; ++x)
      if (std::abs(x - 160) > 8 || std::abs(y - 120) > 8) patch.depth.at(x, y) = NAN;
  incremental.addKeyframe(6, poseOf(scene.cameras[6]), patch);
  EXPECT_LT(incremental.updateMesh(), incremental.blockCount() / 4);

  // Everything removed: nothing left, not even empty blocks.
  for (int64_t id : {1, 2, 3, 6}) incremental.removeKeyframe(id);
  incremental.updateMesh();
  EXPECT_EQ(incremental.blockCount(), 0u);
  EXPECT_TRUE(incremental.mesh().empty());
}

TEST(TsdfMap, WeightsAverageTheDepths) {
  // Two frontal planes 2 cm apart with weights 3 and 1: the surface lies a quarter of the way.
  const PinholeCamera camera = lookAt({0, 0, 0}, {0, 0.001, 1});
  SurfaceDepth near_plane, far_plane;
  near_plane.camera = far_plane.camera = camera;
  near_plane.depth = ImageF(camera.width, camera.height, 1, 1.50f);
  far_plane.depth = ImageF(camera.width, camera.height, 1, 1.52f);
  near_plane.weight = ImageF(camera.width, camera.height, 1, 0.75f);
  far_plane.weight = ImageF(camera.width, camera.height, 1, 0.25f);
  TsdfMap map(oneViewOptions());
  map.addKeyframe(1, poseOf(camera), near_plane);
  map.addKeyframe(2, poseOf(camera), far_plane);
  map.updateMesh();
  const TriangleMesh mesh = map.mesh();
  ASSERT_FALSE(mesh.empty());
  const Eigen::Isometry3d world_to_camera = poseOf(camera).inverse();
  for (const Eigen::Vector3f& p : mesh.vertices.points)
    ASSERT_NEAR((world_to_camera * p.cast<double>()).z(), 1.505, 1e-4);
}

TEST(TsdfMap, MemoryBoundEvictsTheOldestKeyframesAndCountsDrops) {
  const SphereScene scene;
  TsdfMap unbounded;
  unbounded.addKeyframe(0, poseOf(scene.cameras[0]), scene.depth(0));
  const size_t one_view = unbounded.blockCount();
  TsdfMapOptions options;
  options.max_blocks = one_view + one_view / 2;
  TsdfMap map(options);
  map.addKeyframe(0, poseOf(scene.cameras[0]), scene.depth(0));
  const TsdfMapUpdate second = map.addKeyframe(4, poseOf(scene.cameras[4]), scene.depth(4));  // the far side
  ASSERT_EQ(second.evicted_keyframes, std::vector<int64_t>({0}));
  EXPECT_FALSE(map.contains(0));
  EXPECT_LE(map.blockCount(), options.max_blocks);
  EXPECT_EQ(second.dropped_blocks, 0u);

  options.max_blocks = one_view / 2;  // one view alone does not fit
  TsdfMap tiny(options);
  const TsdfMapUpdate update = tiny.addKeyframe(0, poseOf(scene.cameras[0]), scene.depth(0));
  EXPECT_EQ(tiny.blockCount(), options.max_blocks);
  EXPECT_EQ(update.dropped_blocks, one_view - options.max_blocks);
  EXPECT_EQ(tiny.totalDroppedBlocks(), update.dropped_blocks);

}

// Beyond reposable_keyframes the oldest keyframe is frozen: its sums stay
// (the surface is the same as with every keyframe kept), its depth is
// released, and it can no longer be moved, removed or replaced. Blocks only
// frozen keyframes touched and without a voxel at min_weight are erased.
TEST(TsdfMap, FrozenKeyframesStayInTheSurface) {
  const SphereScene scene;
  TsdfMap all(oneViewOptions());
  for (int k = 0; k < 3; ++k) all.addKeyframe(k, poseOf(scene.cameras[k]), scene.depth(k));
  TsdfMapOptions options = oneViewOptions();
  options.reposable_keyframes = 2;
  TsdfMap few(options);
  size_t pruned = 0;
  for (int k = 0; k < 3; ++k) {
    const TsdfMapUpdate update = few.addKeyframe(k, poseOf(scene.cameras[k]), scene.depth(k));
    EXPECT_EQ(update.frozen_keyframes, k == 2 ? std::vector<int64_t>{0} : std::vector<int64_t>{});
    pruned += update.pruned_blocks;
  }
  EXPECT_EQ(few.keyframeCount(), 2u);
  EXPECT_FALSE(few.contains(0));
  EXPECT_TRUE(few.isFrozen(0));
  EXPECT_EQ(few.totalEvictedKeyframes(), 0u);
  EXPECT_EQ(few.blockCount() + pruned, all.blockCount());  // pruned: blocks the rays crossed, no sample in them
  EXPECT_LT(few.memoryBytes(), all.memoryBytes());  // one depth image fewer
  const TriangleMesh a = all.mesh(), b = few.mesh();
  ASSERT_GT(a.triangles.size(), 1000u);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices.points[i], b.vertices.points[i]) << i;
  EXPECT_EQ(a.triangles, b.triangles);

  EXPECT_TRUE(few.addKeyframe(0, poseOf(scene.cameras[3]), scene.depth(3)).refused_frozen);
  EXPECT_EQ(few.mesh().triangles, a.triangles);
  EXPECT_THROW(few.updatePose(0, poseOf(scene.cameras[0])), InputError);
  // Removing the reposable ones leaves the frozen one's surface.
  TsdfMap first(oneViewOptions());
  first.addKeyframe(0, poseOf(scene.cameras[0]), scene.depth(0));
  few.removeKeyframe(1);
  few.removeKeyframe(2);
  EXPECT_LE(few.blockCount(), first.blockCount());
  EXPECT_EQ(few.mesh().triangles, first.mesh().triangles);
}

// Views of one place over and over, each with its own outliers (a pixel in
// a hundred at a random depth, as noisy published depth has): once the
// oldest keyframes are frozen, the outliers' blocks (below min_weight) go,
// and the map hardly grows; the surface stays.
TEST(TsdfMap, RevisitingAPlaceErasesTheFrozenOutliersBlocks) {
  const SphereScene scene;
  TsdfMapOptions options;  // min_weight 2
  options.reposable_keyframes = 8;
  options.max_image_width = 160;
  TsdfMap map(options);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> depth_of_outlier(0.5f, 6.0f);
  size_t blocks_at_24 = 0, pruned = 0;
  for (int k = 0; k < 120; ++k) {
    SurfaceDepth depth = scene.depth(k % 8);
    for (float& d : depth.depth.data)
      if (random() % 100 == 0) d = depth_of_outlier(random);
    pruned += map.addKeyframe(k, poseOf(scene.cameras[k % 8]), depth).pruned_blocks;
    if (k == 23) blocks_at_24 = map.blockCount();
  }
  // What still grows: blocks where outliers of two frozen keyframes met
  // (measured 3316 blocks at 24 keyframes, 3807 at 120, with 38000 pruned:
  // without pruning the map would hold 41000).
  const size_t blocks_at_120 = map.blockCount();
  EXPECT_GT(pruned, 8 * blocks_at_120) << "allocated for outliers and erased again";
  EXPECT_LT(blocks_at_120, blocks_at_24 * 5 / 4) << blocks_at_24;
  const TriangleMesh mesh = map.mesh();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  size_t near_surface = 0;
  for (const Eigen::Vector3f& p : mesh.vertices.points)
    near_surface += std::abs((p.cast<double>() - scene.centre).norm() - scene.radius) < options.voxel_size;
  EXPECT_GT(near_surface, 0.95 * mesh.vertices.size());
}

TEST(TsdfMap, BadInputIsRefusedWithItsReason) {
  const SphereScene scene;
  TsdfMap map(oneViewOptions());
  SurfaceDepth depth = scene.depth(0);
  Eigen::Isometry3d bad_pose = poseOf(scene.cameras[0]);
  bad_pose.translation().x() = NAN;
  const auto message = [&](const std::function<void()>& call) {
    try {
      call();
    } catch (const InputError& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([&] { map.addKeyframe(1, bad_pose, depth); }).find("keyframe 1"), std::string::npos);
  SurfaceDepth wrong_size = depth;
  wrong_size.depth = ImageF(10, 10, 1, 1.0f);
  EXPECT_NE(message([&] { map.addKeyframe(1, poseOf(scene.cameras[0]), wrong_size); }).find("depth must be"),
            std::string::npos);
  SurfaceDepth negative = depth;
  negative.weight = ImageF(depth.camera.width, depth.camera.height, 1, -1.0f);
  EXPECT_NE(message([&] { map.addKeyframe(1, poseOf(scene.cameras[0]), negative); }).find("weights must be"),
            std::string::npos);
  EXPECT_NE(message([&] { map.removeKeyframe(5); }).find("keyframe 5 is not in the map"), std::string::npos);
  EXPECT_EQ(map.keyframeCount(), 0u);
  TsdfMapOptions options;
  options.band_voxels = 0.5;
  EXPECT_NE(message([&] { TsdfMap refused(options); }).find("band_voxels"), std::string::npos);
  // Infinite and negative depths are no depth: no block, no NaN.
  SurfaceDepth odd = depth;
  for (size_t i = 0; i < odd.depth.data.size(); i += 3) odd.depth.data[i] = i % 2 ? INFINITY : -1.0f;
  map.addKeyframe(2, poseOf(scene.cameras[0]), odd);
  map.updateMesh();
  const TriangleMesh mesh = map.mesh();
  ASSERT_FALSE(mesh.empty());
  for (const Eigen::Vector3f& p : mesh.vertices.points) ASSERT_TRUE(p.allFinite());
}

TEST(TsdfMap, WideImagesAreSubsampledWithTheirCamera) {
  const SphereScene scene;
  const PinholeCamera wide = lookAt(scene.cameras[0].center(), scene.centre, 640, 480);
  const SurfaceDepth full = sphereDepth(wide, scene.centre, scene.radius);
  const SurfaceDepth small = subsampledSurfaceDepth(full, 320);
  ASSERT_EQ(small.camera.width, 320);
  ASSERT_EQ(small.camera.height, 240);
  for (int y = 0; y < 240; y += 17)
    for (int x = 0; x < 320; x += 13) {
      const float d = small.depth.at(x, y);
      ASSERT_TRUE(std::isnan(d) ? std::isnan(full.depth.at(2 * x, 2 * y)) : d == full.depth.at(2 * x, 2 * y));
    }
  // The same ray: pixel (x, y) of the small camera is pixel (2x, 2y) of the full one.
  const Eigen::Vector2d a = small.camera.project(Eigen::Vector3d(0.1, -0.2, 1.3));
  const Eigen::Vector2d b = wide.project(Eigen::Vector3d(0.1, -0.2, 1.3));
  EXPECT_NEAR(2 * a.x(), b.x(), 1e-9);
  EXPECT_NEAR(2 * a.y(), b.y(), 1e-9);
}

}  // namespace
}  // namespace amhmvs
