// The whole estimator on a scene the test renders itself (textured slanted
// planes, exact depth, 5 views): accuracy, determinism, ablations.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

// Fraction of pixels with a true depth whose estimate is within `tolerance`
// relative error (no estimate counts as wrong).
double fractionWithin(const ImageF& depth, const ImageF& truth, double tolerance) {
  long total = 0, good = 0;
  for (size_t i = 0; i < truth.data.size(); ++i) {
    const float t = truth.data[i];
    if (!(t > 0)) continue;
    ++total;
    good += std::abs(depth.data[i] - t) <= tolerance * t;
  }
  return total ? static_cast<double>(good) / total : 0.0;
}

class EstimatorOnSyntheticScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { scene_ = new SyntheticProblem(makeSyntheticProblem(320, 240, 4)); }
  static void TearDownTestSuite() { delete scene_; }
  static DepthMap run(const PatchMatchOptions& options = {}) {
    return DepthEstimator(options, Backend::kCpu).estimate(scene_->problem);
  }
  static SyntheticProblem* scene_;
};
SyntheticProblem* EstimatorOnSyntheticScene::scene_ = nullptr;

TEST_F(EstimatorOnSyntheticScene, PaperDefaultsRecoverDepthWithinOnePercent) {
  const DepthMap map = run();
  const double within = fractionWithin(map.depth, scene_->true_depth, 0.01);
  RecordProperty("within_1_percent", std::to_string(within));
  EXPECT_GE(within, 0.97);
  // Normals are unit and face the camera (n . ray < 0); costs are in [0, 2].
  const PinholeCamera& camera = scene_->problem.reference_camera;
  for (int y = 0; y < map.normal.height; y += 7) {
    for (int x = 0; x < map.normal.width; x += 7) {
      const Eigen::Vector3d n(map.normal.at(x, y, 0), map.normal.at(x, y, 1), map.normal.at(x, y, 2));
      EXPECT_NEAR(n.squaredNorm(), 1.0, 1e-4);
      EXPECT_LT(n.dot(camera.backproject(x, y, 1.0)), 0.0);
      EXPECT_GE(map.cost.at(x, y), 0.0f);
      EXPECT_LE(map.cost.at(x, y), 2.0f);
    }
  }
}

TEST_F(EstimatorOnSyntheticScene, SameSeedSameBitsOtherSeedOtherBits) {
  const DepthMap a = run(), b = run();
  ASSERT_EQ(a.depth.data.size(), b.depth.data.size());
  EXPECT_EQ(0, std::memcmp(a.depth.data.data(), b.depth.data.data(), a.depth.data.size() * 4));
  EXPECT_EQ(0, std::memcmp(a.normal.data.data(), b.normal.data.data(), a.normal.data.size() * 4));
  EXPECT_EQ(0, std::memcmp(a.cost.data.data(), b.cost.data.data(), a.cost.data.size() * 4));
  PatchMatchOptions other;
  other.random_seed = 12345;
  const DepthMap c = run(other);
  EXPECT_NE(0, std::memcmp(a.depth.data.data(), c.depth.data.data(), a.depth.data.size() * 4));
}

// The ablations of the paper's Table 1 run and still find most of the scene;
// the full method is at least as accurate as either.
TEST_F(EstimatorOnSyntheticScene, AblationsRunAndAreNotBetterThanThePaper) {
  PatchMatchOptions symmetric, heuristic;
  symmetric.propagation = PropagationScheme::kSymmetric;
  heuristic.view_selection = ViewSelectionScheme::kHeuristicTopK;
  const double paper = fractionWithin(run().depth, scene_->true_depth, 0.01);
  const double acp = fractionWithin(run(symmetric).depth, scene_->true_depth, 0.01);
  const double mhj = fractionWithin(run(heuristic).depth, scene_->true_depth, 0.01);
  std::printf("within 1%%: paper %.4f, symmetric propagation %.4f, heuristic top-K %.4f\n", paper,
              acp, mhj);
  EXPECT_GT(acp, 0.5);
  EXPECT_GT(mhj, 0.5);
  EXPECT_GE(paper + 1e-3, acp);
}

}  // namespace
}  // namespace amhmvs
