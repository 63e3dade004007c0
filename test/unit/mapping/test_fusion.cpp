// Depth-map fusion: exact synthetic depth maps fuse onto the true surface,
// outliers are rejected, each threshold means what the header says, no
// non-finite point comes out, and every class of bad input is refused.
#include <gtest/gtest.h>

#include <deque>
#include <memory>

#include <cmath>
#include <limits>
#include <random>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Rendered views of the slanted-planes scene, each checked against all others.
// The images are owned by `images`; `views` borrow them (a test that changes
// an image's size borrows it again with rebind()).
struct SyntheticViews {
  SyntheticWorld world;
  std::vector<DepthMapImages> images;
  std::vector<FusionView> views;

  SyntheticViews() = default;
  SyntheticViews(const SyntheticViews&) = delete;  // the views would borrow the original's images
  void rebind(int i) {
    FusionView view = images[i].borrow(i, views[i].camera);
    view.source_ids = views[i].source_ids;
    views[i] = view;
  }
};

std::unique_ptr<SyntheticViews> renderScene(int count, int width, int height) {
  auto s = std::make_unique<SyntheticViews>();
  s->world = makeSlantedPlanesWorld(3);
  const std::vector<PinholeCamera> cameras = makeSidewaysCameras(count, width, height);
  s->images.resize(count);
  for (int i = 0; i < count; ++i) {
    RenderedView r = renderView(s->world, cameras[i], 1);
    s->images[i].depth = std::move(r.depth);
    s->images[i].normal = std::move(r.normal);
    s->images[i].color = std::move(r.image);
    FusionView v = s->images[i].borrow(i, r.camera);
    for (int j = 0; j < count; ++j) {
      if (j != i) v.source_ids.push_back(j);
    }
    s->views.push_back(std::move(v));
  }
  return s;
}

// Share of fused points whose depth matches the true surface along their own
// camera ray within `relative` (an outlier would not lie on the surface).
double shareOnSurface(const SyntheticWorld& world, const FusionResult& result, double relative) {
  size_t on = 0, total = 0;
  for (const FusedViewPoints& v : result.views) {
    for (const KeyframePoint& p : v.points) {
      const Eigen::Vector2d uv = v.camera.project(p.position.cast<double>());
      const double truth = depthAt(world, v.camera, uv.x(), uv.y());
      ++total;
      on += std::abs(p.position.z() - truth) < relative * truth;
    }
  }
  return total ? static_cast<double>(on) / total : 0.0;
}

// Fused points farther from the true surface than the disparity check can
// admit. An agreeing source's depth is within f_eps px of parallax of the
// reference's: for baseline b and focal f, |dz| < f_eps z^2 / (f b), largest
// for the smallest baseline; a mean of agreeing points stays within that.
// Rounding moves points by ~1e-7 z, far inside it, so the count does not
// depend on the compiler; a point beyond it is an outlier that got through
// (or a depth-edge artefact of nearest-pixel sampling, present without noise).
size_t outliersBeyondAgreement(const SyntheticViews& s, const FusionResult& result, float f_eps) {
  double min_baseline = std::numeric_limits<double>::infinity();
  for (const FusionView& a : s.views) {
    for (const FusionView& b : s.views) {
      if (a.id != b.id) min_baseline = std::min(min_baseline, (a.camera.center() - b.camera.center()).norm());
    }
  }
  size_t outliers = 0;
  for (const FusedViewPoints& v : result.views) {
    for (const KeyframePoint& p : v.points) {
      const Eigen::Vector2d uv = v.camera.project(p.position.cast<double>());
      const double truth = depthAt(s.world, v.camera, uv.x(), uv.y());
      const double admitted = f_eps * truth * truth / (v.camera.fx * min_baseline);
      outliers += !(std::abs(p.position.z() - truth) < admitted);
    }
  }
  return outliers;
}

std::vector<Eigen::Vector3f> groundTruthCloud(const SyntheticViews& s) {
  std::vector<DepthMapView> maps;
  for (size_t i = 0; i < s.views.size(); ++i) maps.push_back({s.views[i].camera, s.images[i].depth});
  return backprojectDepthMaps(maps, 1);
}

TEST(Fusion, ExactDepthMapsFuseOntoTheTrueSurface) {
  const auto scene = renderScene(5, 320, 240);
  SyntheticViews& s = *scene;
  const FusionResult result = fuseDepthMaps(s.views, FusionOptions::paper());
  const PointCloud cloud = worldCloud(result);
  ASSERT_GT(cloud.size(), 50000u);
  const double on_surface = shareOnSurface(s.world, result, 1e-3);
  const CloudMetrics m = evaluateCloud(cloud.points, groundTruthCloud(s), {0.02, 0.05});
  std::cout << "[ metrics  ] " << cloud.size() << " points of " << result.candidate_pixels
            << " candidates; on surface (0.1 %): " << 100 * on_surface << " %\n"
            << m.table();
  EXPECT_GT(on_surface, 0.995);
  EXPECT_GT(m.accuracy[0], 0.999);
  EXPECT_GT(m.completeness[1], 0.97);
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_TRUE(cloud.points[i].allFinite());
    ASSERT_NEAR(cloud.normals[i].norm(), 1.0f, 1e-4f);
    ASSERT_GT(cloud.confidence[i], 0.0f);
    ASSERT_LE(cloud.confidence[i], 1.0f);
  }
}

TEST(Fusion, EachPixelFusedOnceGivesFewerPointsThanPerViewFusion) {
  const auto scene = renderScene(4, 160, 120);
  SyntheticViews& s = *scene;
  FusionOptions options = FusionOptions::paper();
  const size_t once = fuseDepthMaps(s.views, options).pointCount();
  options.fuse_each_pixel_once = false;
  const FusionResult all = fuseDepthMaps(s.views, options);
  std::cout << "[ counts   ] once: " << once << ", per view: " << all.pointCount() << "\n";
  EXPECT_LT(once * 2, all.pointCount());
  for (const FusedViewPoints& v : all.views) EXPECT_GT(v.points.size(), 10000u);
}

TEST(Fusion, OutliersOfOneViewAreRejectedAndTheRestRemains) {
  const auto scene = renderScene(5, 160, 120);
  SyntheticViews& s = *scene;
  const FusionOptions paper = FusionOptions::paper();
  const FusionResult clean = fuseDepthMaps(s.views, paper);
  // View 2: a block of wrong depths (25 % too far) and salt noise elsewhere
  // (at least 1.5x off: with the smallest baseline, 0.15 m at 6 m, smaller
  // errors can stay within 0.3 px of disparity and rightly pass as agreement).
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(0.5f, 1.0f);
  auto factor = [&](std::mt19937& g) { return (g() % 2) ? 1 + uniform(g) : 1 / (1 + uniform(g)); };
  ImageF& depth = s.images[2].depth;  // the views borrow it
  for (int y = 20; y < 90; ++y) {
    for (int x = 30; x < 120; ++x) depth.at(x, y) *= 1.25f;
  }
  for (int i = 0; i < 2000; ++i) {
    depth.at(static_cast<int>(rng() % 160), static_cast<int>(rng() % 120)) *= factor(rng);
  }
  const FusionResult noisy = fuseDepthMaps(s.views, FusionOptions::paper());
  const double on_surface = shareOnSurface(s.world, noisy, 1e-3);
  const auto gt = groundTruthCloud(*renderScene(5, 160, 120));
  const double clean_completeness = evaluateCloud(worldCloud(clean).points, gt, {0.1}).completeness[0];
  const double noisy_completeness = evaluateCloud(worldCloud(noisy).points, gt, {0.1}).completeness[0];
  const double clean_on_surface = shareOnSurface(s.world, clean, 1e-3);
  std::cout << "[ outliers ] points " << clean.pointCount() << " -> " << noisy.pointCount()
            << ", on surface " << 100 * clean_on_surface << " % -> " << 100 * on_surface
            << " %, completeness "
            << 100 * clean_completeness << " % -> " << 100 * noisy_completeness << " %\n";
  // No corrupted depth gets through: no more points beyond what agreement
  // admits than without the noise (an exact count, not a share with a margin).
  const size_t clean_outliers = outliersBeyondAgreement(s, clean, paper.max_disparity_difference);
  const size_t noisy_outliers = outliersBeyondAgreement(s, noisy, paper.max_disparity_difference);
  std::cout << "[ outliers ] beyond agreement: " << clean_outliers << " -> " << noisy_outliers << "\n";
  EXPECT_LE(noisy_outliers, clean_outliers);
  // The count sees outliers: with a check 10x looser the corrupted view's depths get through.
  FusionOptions loose = paper;
  loose.max_disparity_difference *= 10;
  const size_t loose_outliers =
      outliersBeyondAgreement(s, fuseDepthMaps(s.views, loose), paper.max_disparity_difference);
  std::cout << "[ outliers ] beyond agreement with a 3 px check: " << loose_outliers << "\n";
  EXPECT_GT(loose_outliers, clean_outliers + 100);
  EXPECT_GT(noisy_completeness, clean_completeness - 0.02);
  // None of view 2's own points comes from the corrupted block.
  for (const KeyframePoint& p : noisy.views[2].points) {
    const Eigen::Vector2d uv = noisy.views[2].camera.project(p.position.cast<double>());
    EXPECT_FALSE(uv.x() > 32 && uv.x() < 118 && uv.y() > 22 && uv.y() < 88) << uv.transpose();
  }
}

// Two or three parallel cameras 0.2 m apart facing a fronto-parallel plane at
// z = 4 m: the disparity between neighbours is f * b / z = 50 * 0.2 / 4 = 2.5 px.
class FusionThresholds : public ::testing::Test {
 protected:
  FusionView planeView(int id, double x, float depth_scale, const Eigen::Vector3f& normal) {
    DepthMapImages& images = owned_.emplace_back();
    images.depth = ImageF(64, 48, 1, 4.0f * depth_scale);
    images.normal = ImageF(64, 48, 3);
    for (int y = 0; y < 48; ++y) {
      for (int c = 0; c < 64; ++c) {
        for (int k = 0; k < 3; ++k) images.normal.at(c, y, k) = normal[k];
      }
    }
    PinholeCamera camera = test::centredCamera(64, 48, 50);
    camera.t = Eigen::Vector3d(-x, 0, 0);
    return images.borrow(id, camera);
  }
  // The images of the views made here (a deque: they stay where they are).
  std::deque<DepthMapImages> owned_;
  // Points of view 0 fused against view 1 whose depths are scaled by `scale`
  // and whose normals are `normal`.
  size_t pointsOfView0(const FusionOptions& options, float scale,
                              const Eigen::Vector3f& normal = -Eigen::Vector3f::UnitZ()) {
    std::vector<FusionView> views = {planeView(0, 0.0, 1.0f, -Eigen::Vector3f::UnitZ()),
                                     planeView(1, 0.2, scale, normal)};
    views[0].source_ids = {1};
    return fuseDepthMaps(views, options).views[0].points.size();
  }
  static FusionOptions oneView(FusionOptions o) {
    o.min_consistent_views = 1;
    return o;
  }
  static Eigen::Vector3f tilted(double degrees) {
    const double a = degrees * M_PI / 180;
    return Eigen::Vector3f(0, static_cast<float>(std::sin(a)), -static_cast<float>(std::cos(a)));
  }
};

TEST_F(FusionThresholds, DisparityDifferenceIsFocalTimesBaselineOverDepthInTheSource) {
  const FusionOptions paper = oneView(FusionOptions::paper());  // 0.3 px
  // Disparity difference = 2.5 * |1 - 1/s| px.
  EXPECT_GT(pointsOfView0(paper, 1.0f / 0.9f), 1000u);    // 0.25 px
  EXPECT_EQ(pointsOfView0(paper, 1.0f / 0.86f), 0u);      // 0.35 px
  EXPECT_GT(pointsOfView0(paper, 1.0f / 1.1f), 1000u);    // 0.25 px, nearer
  EXPECT_EQ(pointsOfView0(paper, 1.0f / 1.14f), 0u);      // 0.35 px, nearer
}

TEST_F(FusionThresholds, NormalAngle) {
  const FusionOptions paper = oneView(FusionOptions::paper());  // 30 degrees
  EXPECT_GT(pointsOfView0(paper, 1.0f, tilted(25)), 1000u);
  EXPECT_EQ(pointsOfView0(paper, 1.0f, tilted(35)), 0u);
  const FusionOptions reprojection = oneView(FusionOptions::reprojection());  // 10 degrees
  EXPECT_GT(pointsOfView0(reprojection, 1.0f, tilted(8)), 1000u);
  EXPECT_EQ(pointsOfView0(reprojection, 1.0f, tilted(12)), 0u);
}

TEST_F(FusionThresholds, RelativeDepthDifferenceInTheReference) {
  const FusionOptions reprojection = oneView(FusionOptions::reprojection());  // 1 %
  EXPECT_GT(pointsOfView0(reprojection, 1.009f), 1000u);
  EXPECT_EQ(pointsOfView0(reprojection, 1.011f), 0u);
  EXPECT_GT(pointsOfView0(reprojection, 0.991f), 1000u);
  EXPECT_EQ(pointsOfView0(reprojection, 0.989f), 0u);
}

TEST_F(FusionThresholds, ReprojectionErrorInPixels) {
  // X lands 2.5 px left in view 1; its nearest pixel is 0.5 px off, so the
  // source point reprojects exactly 0.5 px from the reference pixel.
  FusionOptions options = oneView(FusionOptions::reprojection());
  options.max_reprojection_error = 0.55f;
  EXPECT_GT(pointsOfView0(options, 1.0f), 1000u);
  options.max_reprojection_error = 0.45f;
  EXPECT_EQ(pointsOfView0(options, 1.0f), 0u);
}

TEST_F(FusionThresholds, MinimumConsistentViewsAndConfidence) {
  std::vector<FusionView> views = {planeView(0, 0.0, 1.0f, -Eigen::Vector3f::UnitZ()),
                                   planeView(1, 0.2, 1.0f, -Eigen::Vector3f::UnitZ()),
                                   planeView(2, -0.2, 1.5f, -Eigen::Vector3f::UnitZ())};
  views[0].source_ids = {1, 2};
  FusionOptions options = FusionOptions::paper();
  options.fuse_each_pixel_once = false;
  EXPECT_EQ(fuseDepthMaps(views, options).views[0].points.size(), 0u);  // only view 1 agrees
  options.min_consistent_views = 1;
  const FusionResult result = fuseDepthMaps(views, options);
  ASSERT_GT(result.views[0].points.size(), 1000u);
  for (const KeyframePoint& p : result.views[0].points) {
    EXPECT_EQ(p.consistent_views, 1);
    // Seen by both sources (0.5) or only by the agreeing one near the border (1).
    EXPECT_TRUE(p.confidence == 0.5f || p.confidence == 1.0f) << p.confidence;
    EXPECT_NEAR(p.position.z(), 4.0f, 1e-4f);
  }
  // max_sources 1 keeps only view 1: still one agreeing view.
  options.max_sources = 1;
  EXPECT_EQ(fuseDepthMaps(views, options).views[0].points.size(),
            result.views[0].points.size());
}

TEST_F(FusionThresholds, CostMaskIgnoresExpensivePixels) {
  std::vector<FusionView> views = {planeView(0, 0.0, 1.0f, -Eigen::Vector3f::UnitZ()),
                                   planeView(1, 0.2, 1.0f, -Eigen::Vector3f::UnitZ())};
  views[0].source_ids = {1};
  const ImageF cost(64, 48, 1, 0.8f);
  views[1].cost = cost;
  FusionOptions options = oneView(FusionOptions::paper());
  EXPECT_GT(fuseDepthMaps(views, options).views[0].points.size(), 1000u);
  options.max_cost = 0.5f;
  EXPECT_EQ(fuseDepthMaps(views, options).views[0].points.size(), 0u);
}

TEST(Fusion, NoNonFinitePointFromNonFiniteInput) {
  const auto scene = renderScene(4, 120, 90);
  SyntheticViews& s = *scene;
  std::mt19937 rng(11);
  const float bad_depths[] = {kNaN, std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(), 0.0f, -1.0f, 1e-30f,
                              1e30f};
  for (size_t view = 0; view < s.images.size(); ++view) {
    DepthMapImages& v = s.images[view];
    for (int i = 0; i < 3000; ++i) {
      const int x = static_cast<int>(rng() % 120), y = static_cast<int>(rng() % 90);
      v.depth.at(x, y) = bad_depths[rng() % 7];
    }
    for (int i = 0; i < 3000; ++i) {
      const int x = static_cast<int>(rng() % 120), y = static_cast<int>(rng() % 90);
      const float value = (rng() % 2) ? kNaN : 0.0f;
      for (int k = 0; k < 3; ++k) v.normal.at(x, y, k) = value;
    }
    v.cost = ImageF(120, 90, 1, 0.1f);
    for (int i = 0; i < 500; ++i) v.cost.data[rng() % v.cost.data.size()] = kNaN;
    s.rebind(static_cast<int>(view));  // a cost map was added
  }
  for (FusionOptions options : {FusionOptions::paper(), FusionOptions::reprojection()}) {
    options.max_cost = 1.0f;
    options.min_consistent_views = 1;
    const PointCloud cloud = worldCloud(fuseDepthMaps(s.views, options));
    ASSERT_GT(cloud.size(), 1000u);
    for (size_t i = 0; i < cloud.size(); ++i) {
      ASSERT_TRUE(cloud.points[i].allFinite()) << i;
      ASSERT_TRUE(cloud.normals[i].allFinite()) << i;
      ASSERT_TRUE(std::isfinite(cloud.confidence[i])) << i;
    }
  }
}

TEST(Fusion, CameraFramePointsDoNotDependOnTheWorldFrame) {
  const auto scene = renderScene(3, 100, 75);
  SyntheticViews& s = *scene;
  const FusionResult original = fuseDepthMaps(s.views, FusionOptions::paper());
  // Move the whole rig: X_world' = Q X_world + c, so R' = R Q^T, t' = t - R' c.
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d c(5, -3, 2);
  for (FusionView& v : s.views) {
    v.camera.R = v.camera.R * Q.transpose();
    v.camera.t = v.camera.t - v.camera.R * c;
  }
  const FusionResult moved = fuseDepthMaps(s.views, FusionOptions::paper());
  ASSERT_EQ(moved.pointCount(), original.pointCount());
  for (size_t v = 0; v < moved.views.size(); ++v) {
    for (size_t i = 0; i < moved.views[v].points.size(); ++i) {
      const KeyframePoint& a = original.views[v].points[i];
      const KeyframePoint& b = moved.views[v].points[i];
      ASSERT_LT((a.position - b.position).norm(), 1e-4f);
      // toWorld follows the pose: the moved world point is Q X + c.
      const Eigen::Vector3f expected =
          (Q * toWorld(a, original.views[v].camera).position.cast<double>() + c).cast<float>();
      ASSERT_LT((toWorld(b, moved.views[v].camera).position - expected).norm(), 1e-4f);
    }
  }
}

TEST(Fusion, DeterministicAcrossRuns) {
  const auto scene = renderScene(3, 100, 75);
  SyntheticViews& s = *scene;
  const PointCloud a = worldCloud(fuseDepthMaps(s.views, FusionOptions::paper()));
  const PointCloud b = worldCloud(fuseDepthMaps(s.views, FusionOptions::paper()));
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.points[i], b.points[i]);
}

TEST(Fusion, BadInputIsRefused) {
  const auto scene = renderScene(3, 40, 30);
  SyntheticViews& s = *scene;
  const FusionOptions paper = FusionOptions::paper();
  EXPECT_INPUT_ERROR(fuseDepthMaps({}, paper), "fusion", "no views");
  {
    auto views = s.views;
    const ImageF wrong(41, 30);
    views[1].depth = wrong;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 1", "depth map is 41x30");
  }
  {
    auto views = s.views;
    const ImageF wrong(40, 30, 1);
    views[2].normal = wrong;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 2", "normal map");
  }
  {
    auto views = s.views;
    const ImageU8 wrong(40, 30, 2);
    views[0].color = wrong;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 0", "colour");
  }
  {
    auto views = s.views;
    const ImageF wrong(10, 30);
    views[0].cost = wrong;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 0", "cost");
  }
  {
    auto views = s.views;
    views[0].source_ids.push_back(17);
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 0", "unknown source view id 17");
  }
  {
    auto views = s.views;
    views[1].source_ids.push_back(1);
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 1", "itself");
  }
  {
    auto views = s.views;
    views[1].source_ids.push_back(views[1].source_ids.front());
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 1", "twice");
  }
  {
    auto views = s.views;
    views[2].id = 0;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 0", "twice");
  }
  {
    auto views = s.views;
    views[1].camera.t.x() = std::numeric_limits<double>::quiet_NaN();
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 1", "non-finite");
  }
  {
    auto views = s.views;
    views[2].camera.R *= 1.1;
    EXPECT_INPUT_ERROR(fuseDepthMaps(views, paper), "view 2", "not rigid");
  }
  {
    FusionOptions o = paper;
    o.max_disparity_difference = -1;
    EXPECT_INPUT_ERROR(fuseDepthMaps(s.views, o), "options", "max_disparity_difference");
    o = paper;
    o.max_normal_angle_deg = kNaN;
    EXPECT_INPUT_ERROR(fuseDepthMaps(s.views, o), "options", "max_normal_angle_deg");
    o = paper;
    o.min_consistent_views = -1;
    EXPECT_INPUT_ERROR(fuseDepthMaps(s.views, o), "options", "min_consistent_views");
    o = paper;
    o.max_disparity_difference = FusionOptions::kOff;
    EXPECT_INPUT_ERROR(fuseDepthMaps(s.views, o), "options", "no depth check");
  }
  EXPECT_EQ(FusionOptions::paper().validate(), "");
  EXPECT_EQ(FusionOptions::reprojection().validate(), "");
}

}  // namespace
}  // namespace amhmvs
