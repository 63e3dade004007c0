// GPU-failure handling of the mapping nodelet (fallback_estimator.h) with an
// injected failing backend.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/fallback_estimator.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

DepthMap mapFrom(Backend backend) {
  DepthMap map;
  map.backend = backend;
  return map;
}

TEST(FallbackEstimator, FailingGpuRunsTheKeyframeOnTheCpuThenSwitches) {
  int gpu_calls = 0;
  std::vector<bool> gpu_fails = {false, true, false, true, true};  // then it would work again
  std::vector<std::string> reports;
  FallbackEstimator estimate(
      [&](const DepthProblem&) {
        const bool fail = gpu_calls < static_cast<int>(gpu_fails.size()) && gpu_fails[gpu_calls];
        ++gpu_calls;
        if (fail) throw BackendError("injected: out of memory");
        return mapFrom(Backend::kCuda);
      },
      [](const DepthProblem&) { return mapFrom(Backend::kCpu); }, 2,
      [&](const std::string& line) { reports.push_back(line); });
  const DepthProblem problem;
  EXPECT_EQ(estimate(problem).backend, Backend::kCuda);
  EXPECT_EQ(estimate(problem).backend, Backend::kCpu);   // failure 1: this keyframe on the CPU
  EXPECT_EQ(estimate(problem).backend, Backend::kCuda);  // success resets the count
  EXPECT_EQ(estimate(problem).backend, Backend::kCpu);   // failure 1
  EXPECT_FALSE(estimate.switched());
  EXPECT_EQ(estimate(problem).backend, Backend::kCpu);   // failure 2 in a row: switch
  EXPECT_TRUE(estimate.switched());
  EXPECT_EQ(estimate(problem).backend, Backend::kCpu);   // the GPU is not tried again
  EXPECT_EQ(gpu_calls, 5);
  EXPECT_EQ(estimate.fallbacks(), 3u);
  ASSERT_EQ(reports.size(), 3u);
  EXPECT_NE(reports[0].find("out of memory"), std::string::npos);
  EXPECT_NE(reports[2].find("every later keyframe"), std::string::npos);
}

TEST(FallbackEstimator, WithoutFallbackTheErrorReachesTheCaller) {
  FallbackEstimator estimate([](const DepthProblem&) -> DepthMap { throw BackendError("injected: device lost"); },
                             nullptr, 1, nullptr);
  EXPECT_THROW(estimate(DepthProblem()), BackendError);
}

TEST(FallbackEstimator, InputErrorsAreNotRetried) {
  int cpu_calls = 0;
  FallbackEstimator estimate([](const DepthProblem&) -> DepthMap { throw InputError("bad problem"); },
                             [&](const DepthProblem&) {
                               ++cpu_calls;
                               return mapFrom(Backend::kCpu);
                             },
                             1, nullptr);
  EXPECT_THROW(estimate(DepthProblem()), InputError);
  EXPECT_EQ(cpu_calls, 0);
  EXPECT_THROW(FallbackEstimator(nullptr, nullptr, 1, nullptr), InputError);
}

// The real CPU backend as the fallback of a failing primary.
TEST(FallbackEstimator, RealCpuBackendAsFallback) {
  DepthProblem problem;
  problem.reference_camera = test::centredCamera(16, 16, 20);
  ImageU8 image(16, 16, 1, 0);
  for (int i = 0; i < 256; ++i) image.data[i] = static_cast<uint8_t>((i * 37) % 251);
  problem.reference_image = image;
  PinholeCamera source = problem.reference_camera;
  source.t.x() = -0.1;
  problem.source_cameras = {source};
  problem.source_images = {image};
  problem.depth_min = 1;
  problem.depth_max = 3;
  PatchMatchOptions options;
  options.num_iterations = 1;
  const DepthEstimator cpu(options, Backend::kCpu);
  FallbackEstimator estimate([](const DepthProblem&) -> DepthMap { throw BackendError("injected: lost device"); },
                             [&](const DepthProblem& p) { return cpu.estimate(p); }, 1, nullptr);
  const DepthMap map = estimate(problem);
  EXPECT_EQ(map.backend, Backend::kCpu);
  EXPECT_EQ(map.depth.width, 16);
  EXPECT_TRUE(estimate.switched());
}

}  // namespace
}  // namespace amhmvs
