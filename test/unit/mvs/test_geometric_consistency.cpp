// The geometric-consistency term (geometric_consistency.h) and the
// geometric pass of amhmvs_depth (--geometric).
#include "amhmvs_mapping/mvs/geometric_consistency.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <cstdio>
#include <limits>
#include <vector>

#include "mvs/backends.h"
#include "amhmvs_mapping/eval/depth_metrics.h"
#include "depth_job.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

// Reference at the origin, source 0.3 m to the right, both looking along +z
// at a fronto-parallel wall 4 m away; the source's depth map says 4 m (or
// what a test writes into it).
struct TwoViewWall {
  PinholeCamera ref = test::centredCamera(64, 48, 60), src = test::centredCamera(64, 48, 60);
  ImageU8 image{64, 48};
  ImageF source_depth{64, 48};
  DepthProblem problem;
  PatchMatchParams P;
  GeometricTerm term{true, 0.2f, 3.0f};

  TwoViewWall() {
    src.t = Eigen::Vector3d(-0.3, 0, 0);  // camera centre at x = +0.3
    for (float& d : source_depth.data) d = 4.0f;
    problem.reference_camera = ref;
    problem.reference_image = image;
    problem.source_cameras = {src};
    problem.source_images = {image};
    problem.source_depths = {source_depth};
    problem.depth_min = 1;
    problem.depth_max = 10;
    P = makePatchMatchParams(PatchMatchOptions(), problem);
    P.back[0].depth_offset = 0;
  }
  float error(float depth, int x, int y) const {
    const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
    const Plane plane = planeFromDepthNormal({0, 0, -1}, depth, ray);
    return reprojectionError(term, P.sources[0], P.back[0], source_depth.data.data(), plane, ray, x, y);
  }
};

TEST(GeometricConsistency, ConsistentDepthReprojectsOntoItself) {
  const TwoViewWall wall;
  EXPECT_TRUE(wall.P.geometric.enabled);
  for (int y : {10, 24, 40}) {
    for (int x : {20, 32, 50}) EXPECT_LT(wall.error(4.0f, x, y), 0.02f) << x << ", " << y;
  }
}

TEST(GeometricConsistency, WrongDepthGivesTheParallaxDifferenceAndIsCapped) {
  // At 3.5 m the point lands at disparity f b / 3.5 in the source, where the
  // source says 4 m; back in the reference that is f b (1/3.5 - 1/4) pixels
  // off along x (60 px focal, 0.3 m baseline: 0.643 px).
  const TwoViewWall wall;
  const float expected = 60.0f * 0.3f * (1.0f / 3.5f - 1.0f / 4.0f);
  // (The wall's depth is 4 m at every source pixel, so the nearest-pixel
  // lookup does not matter.)
  EXPECT_NEAR(wall.error(3.5f, 32, 24), expected, 0.01f);
  EXPECT_FLOAT_EQ(wall.error(1.5f, 32, 24), 3.0f);  // 4.5 px: capped at tau
}

TEST(GeometricConsistency, MissingDepthOrOutsideCostsTheCap) {
  TwoViewWall wall;
  wall.source_depth.at(32 - 5, 24) = std::numeric_limits<float>::quiet_NaN();  // disparity 4.5 px at 4 m
  wall.source_depth.at(32 - 4, 24) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FLOAT_EQ(wall.error(4.0f, 32, 24), 3.0f);
  EXPECT_FLOAT_EQ(wall.error(4.0f, 0, 24), 3.0f);  // projects left of the source image
  wall.P.back[0].depth_offset = -1;                 // that source has no depth map
  EXPECT_FLOAT_EQ(wall.error(4.0f, 40, 24), 3.0f);
}

TEST(GeometricConsistency, ProblemChecksTheGeometricInputs) {
  TwoViewWall wall;
  ImageF small(32, 24), normals(64, 48, 3);
  wall.problem.source_depths = {small};
  EXPECT_NE(wall.problem.validate().find("source depth map 0: 32x24x1 but its camera is 64x48"), std::string::npos)
      << wall.problem.validate();
  wall.problem.source_depths = {wall.source_depth, wall.source_depth};
  EXPECT_NE(wall.problem.validate().find("2 source depth maps for 1 source views"), std::string::npos);
  wall.problem.source_depths = {wall.source_depth};
  wall.problem.prior_depth = wall.source_depth;
  EXPECT_NE(wall.problem.validate().find("prior depth and prior normal map must be given together"),
            std::string::npos);
  wall.problem.prior_normal = normals;
  EXPECT_EQ(wall.problem.validate(), "");
  wall.problem.prior_normal = wall.source_depth;  // 1 channel
  EXPECT_NE(wall.problem.validate().find("must be 1 and 3 channels"), std::string::npos);
}

TEST(GeometricConsistency, WithoutDepthMapsTheEstimateIsUnchanged) {
  // No source depth maps: the term is off and the result is the photometric
  // one bit for bit (the options' geometric values are not used).
  const std::string folder = test::dataPath("mvsnet/middlebury2014_Piano");
  AMHMVS_REQUIRE_DATA(data, "mvsnet/middlebury2014_Piano");
  const Scene scene = readInputFolder(folder, 1);
  ProblemOptions problem_options;
  problem_options.max_image_size = 160;
  const OwnedDepthProblem owned = makeDepthProblem(scene, 0, problem_options);
  PatchMatchOptions other = PatchMatchOptions();
  other.geometric_weight = 1.0f;
  other.geometric_max_error = 7.0f;
  const DepthMap a = DepthEstimator(PatchMatchOptions(), Backend::kCpu).estimate(owned.problem);
  const DepthMap b = DepthEstimator(other, Backend::kCpu).estimate(owned.problem);
  EXPECT_EQ(std::memcmp(a.depth.data.data(), b.depth.data.data(), a.depth.data.size() * sizeof(float)), 0);
}

// Both views of two of the two-view Middlebury scenes (the two hardest: a
// CPU job takes about 22 s a scene on 2 cores) photometrically, then the
// geometric pass; view 0 against the ground truth (non-occluded pixels). One
// job per scene gives both: its first pass is the photometric estimate with
// the paper's defaults. Measured on the CPU (photometric / geometric pass):
// Piano 72.80 / 79.33 / 85.31 and 74.26 / 80.43 / 86.51 %, Playtable
// 64.26 / 74.08 / 81.57 and 67.21 / 77.32 / 84.55 % within 1 / 2 / 5 %; the
// photometric floors lie 0.3 points below the pooled 68.70 / 76.81 / 83.51 %.
// All four scenes (Adirondack 85.61 / 91.05 / 93.90 %, Motorcycle 81.75 /
// 88.34 / 92.17 %; pooled 76.68 / 83.68 / 88.59 %) are held to the public
// implementation's 75.4 / 82.8 / 87.7 % (its photometric depth maps) on both
// backends by amhmvs_gpu_tests on the GPU machine.
TEST(GeometricConsistency, GeometricPassImprovesMiddleburyOnTheCpu) {
  AMHMVS_REQUIRE_DATA(mvsnet, "mvsnet");
  AccuracyCounts photometric, geometric;
  for (const char* scene : {"Piano", "Playtable"}) {
    const MiddleburyGroundTruth gt = readMiddleburyGroundTruth(test::dataDir() + "/middlebury2014/" + scene);
    DepthJobOptions options;
    options.backend = Backend::kCpu;
    options.quiet = true;
    options.problem.max_sources = 1;
    options.geometric_iterations = 3;
    AccuracyCounts scene_photometric, scene_geometric;
    const auto score = [&](AccuracyCounts* counts, int id, const DepthMap& map) {
      if (id == 0) counts->merge(denseDepthAccuracy(map.depth, gt.depth, &gt.nonoccluded));
    };
    runDepthJob(
        mvsnet + "/middlebury2014_" + scene, "", options,
        [&](int id, const DepthProblem&, const DepthMap& map) { score(&scene_geometric, id, map); },
        [&](int id, const DepthMap& map) { score(&scene_photometric, id, map); });
    std::printf("middlebury %s: photometric %s %%, geometric pass %s %% (%ld pixels)\n", scene,
                scene_photometric.percentages().c_str(), scene_geometric.percentages().c_str(),
                scene_photometric.total);
    photometric.merge(scene_photometric);
    geometric.merge(scene_geometric);
  }
  std::printf("middlebury Piano and Playtable pooled, photometric %s %%, geometric pass %s %%\n",
              photometric.percentages().c_str(), geometric.percentages().c_str());
  RecordProperty("photometric", photometric.percentages());
  RecordProperty("geometric", geometric.percentages());
  const double floors[3] = {68.4, 76.5, 83.2};
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(100.0 * photometric.fraction(i), floors[i]) << "photometric within "
                                                          << 100 * photometric.thresholds[i] << " %";
    EXPECT_GT(geometric.fraction(i), photometric.fraction(i) + 0.005) << i;
  }
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
