// Accuracy on the real data with the paper's defaults, on the CPU backend
// (the paper's photometric depth maps, 3 iterations). The public
// implementation's numbers, measured with the same metrics, are held on all
// views for both backends by test/gpu/gpu_tests.cpp on the GPU machine, and
// Middlebury's there too (here: two of its scenes in
// GeometricConsistency.GeometricPassImprovesMiddleburyOnTheCpu, test/unit/mvs).
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

// Every observation of the triangulated SIFT points by three of the 11 views
// (the first, the middle and the last: a CPU estimate at 768x512 takes about
// 23 s a view on 2 cores). Measured: 98.30 / 99.32 / 99.59 % over 5888
// observations (per view 98.26 / 99.13 / 99.46, 99.14 / 99.51 / 99.74 and
// 97.05 / 99.19 / 99.48 %); the floors lie 0.2-0.3 points below. The pooled
// floor of all 11 views against the public implementation (98.3 / 99.2 /
// 99.5 %; the CPU measured 98.43 / 99.25 / 99.55) is held for both backends by
// amhmvs_gpu_tests (its CPU fountain) on the GPU machine.
TEST(RealData, FountainSparsePointAgreementOnThreeViews) {
  AMHMVS_REQUIRE_DATA(folder, "mvsnet/fountain_x0.25");
  const double floors[3] = {98.0, 99.1, 99.4};
  const std::vector<SparsePoint> points = readSparsePoints(folder + "/sparse_points.txt");
  AccuracyCounts pooled;
  DepthJobOptions options;
  options.backend = Backend::kCpu;
  options.reference_ids = {0, 5, 10};
  std::vector<int> estimated;
  runDepthJob(folder, "", options, [&](int id, const DepthProblem& problem, const DepthMap& map) {
    const AccuracyCounts view = sparsePointAccuracy(map.depth, problem.reference_camera, id, points);
    std::printf("view %d: %s %% over %ld\n", id, view.percentages().c_str(), view.total);
    pooled.merge(view);
    estimated.push_back(id);
  });
  EXPECT_EQ(estimated, options.reference_ids);
  std::printf("fountain_x0.25 views 0, 5, 10: sparse agreement %s %% over %ld observations\n",
              pooled.percentages().c_str(), pooled.total);
  RecordProperty("pooled", pooled.percentages());
  EXPECT_GT(pooled.total, 5000);
  expectAtLeast(pooled, floors, "fountain views 0, 5, 10");
}

}  // namespace
}  // namespace amhmvs
