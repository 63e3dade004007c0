// Accuracy on the real data with the paper's defaults, on the CPU backend,
// against the public implementation's numbers (its photometric depth maps,
// 3 iterations, measured with the same metrics). The GPU backend is held to
// the same floors by test/gpu/gpu_tests.cpp on the GPU machine. Middlebury's
// floors are checked by GeometricConsistency.GeometricPassImprovesMiddleburyOnTheCpu
// (test/unit/mvs), whose photometric pass is the same estimate.
#include <gtest/gtest.h>

#include <cstdio>

#include "amhmvs_mapping/eval/depth_metrics.h"
#include "depth_job.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// Percent within 1 / 2 / 5 % relative depth error.
void expectAtLeast(const AccuracyCounts& counts, const double floors[3], const char* what) {
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(100.0 * counts.fraction(i), floors[i])
        << what << " within " << 100 * counts.thresholds[i] << " %";
  }
}

// Every observation of the triangulated SIFT points by the 11 views.
TEST(RealData, FountainSparsePointAgreementAtLeastPublicImplementation) {
  AMHMVS_REQUIRE_DATA(folder, "mvsnet/fountain_x0.25");
  const double floors[3] = {98.3, 99.2, 99.5};
  const std::vector<SparsePoint> points = readSparsePoints(folder + "/sparse_points.txt");
  AccuracyCounts pooled;
  DepthJobOptions options;
  options.backend = Backend::kCpu;
  int maps = 0;
  runDepthJob(folder, "", options, [&](int id, const DepthProblem& problem, const DepthMap& map) {
    pooled.merge(sparsePointAccuracy(map.depth, problem.reference_camera, id, points));
    ++maps;
  });
  EXPECT_EQ(maps, 11);
  std::printf("fountain_x0.25 sparse agreement %s %% over %ld observations "
              "(public implementation 98.3 / 99.2 / 99.5)\n",
              pooled.percentages().c_str(), pooled.total);
  RecordProperty("pooled", pooled.percentages());
  EXPECT_GT(pooled.total, 20000);
  expectAtLeast(pooled, floors, "fountain");
}

}  // namespace
}  // namespace amhmvs
