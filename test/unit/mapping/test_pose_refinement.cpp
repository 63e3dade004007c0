// Pose refinement before stereo (mapping/pose_refinement.h) on the folded
// planes (synthetic_problem.h: exact cameras, true depth): a known error put
// into a source's pose is removed; what the features cannot tell (no
// texture) and implausible corrections keep the tracker's pose and say so;
// bad options are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "pose_error.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

#define AMHMVS_REQUIRE_POSE_REFINEMENT()                                              \
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage()

using test::withPoseError;

// Mean distance in pixels between where two cameras of one source see the
// reference's true surface: the error stereo suffers.
double meanImageMotionPx(const SyntheticProblem& scene, const PinholeCamera& a, const PinholeCamera& b) {
  return test::meanImageMotionPx(scene.problem.reference_camera, scene.true_depth, a, b);
}

class PoseRefinementScene : public ::testing::Test {
 protected:
  // 320x240, reference and two sources 0.15 m apart, 2.5-4 m away.
  PoseRefinementScene() : scene_(makeSyntheticProblem(320, 240, 2)) {
    true_sources_ = scene_.problem.source_cameras;
  }
  SyntheticProblem scene_;
  std::vector<PinholeCamera> true_sources_;
};

TEST_F(PoseRefinementScene, RemovesAKnownPoseErrorOfASource) {
  AMHMVS_REQUIRE_POSE_REFINEMENT();
  // 12 mm and 0.5 degrees: about 3 px at 320 px, a tracker's error.
  DepthProblem& problem = scene_.problem;
  problem.source_cameras[0] =
      withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const PinholeCamera reference_before = problem.reference_camera;
  const double error_before = meanImageMotionPx(scene_, problem.source_cameras[0], true_sources_[0]);
  PoseRefiner refiner{PoseRefinementOptions()};
  const PoseRefinementResult result = refiner.refine(&problem);
  ASSERT_TRUE(result.ran);
  ASSERT_EQ(result.sources.size(), 2u);
  const double error_after = meanImageMotionPx(scene_, problem.source_cameras[0], true_sources_[0]);
  const double exact_source_after = meanImageMotionPx(scene_, problem.source_cameras[1], true_sources_[1]);
  std::cout << "mean image motion of the perturbed source: " << error_before << " -> " << error_after
            << " px; the exact source moved " << exact_source_after << " px; inliers " << result.sources[0].inliers
            << ", RMS " << result.sources[0].rms_before_px << " -> " << result.sources[0].rms_after_px << " px, "
            << result.total_ms << " ms\n";
  // Measured: 3.01 -> 0.011 px. The exact source is confirmed (kept) and
  // anchors the scale that features cannot see (without it the prior would
  // share the 4 mm error along the baseline between both: 0.2 px each).
  EXPECT_GT(error_before, 2.9);
  EXPECT_LT(error_after, 0.05);
  EXPECT_EQ(exact_source_after, 0);
  EXPECT_EQ(result.sources[0].outcome, SourcePoseOutcome::kRefined);
  EXPECT_EQ(result.sources[1].outcome, SourcePoseOutcome::kConfirmed);
  for (const SourcePoseRefinement& source : result.sources) EXPECT_GE(source.inliers, 100);
  // Distance from the epipolar lines, measured 1.50 -> 0.07 px (390 inliers).
  EXPECT_GT(result.sources[0].rms_before_px, 1.2);
  EXPECT_LT(result.sources[0].rms_after_px, 0.15);
  EXPECT_GT(result.sources[0].correction_m, 0.005);
  EXPECT_GT(result.sources[0].correction_deg, 0.3);
  // The reference camera, and with it the depth map's frame, stays.
  EXPECT_EQ(problem.reference_camera.R, reference_before.R);
  EXPECT_EQ(problem.reference_camera.t, reference_before.t);
}

// With the features weighed by their size (finest_feature_size_px), the
// error is removed as well: a coarse match weighs less, not nothing.
TEST_F(PoseRefinementScene, FeaturesWeighedBySizeRemoveTheErrorToo) {
  AMHMVS_REQUIRE_POSE_REFINEMENT();
  DepthProblem& problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  PoseRefinementOptions options;
  options.finest_feature_size_px = 2;
  PoseRefiner refiner(options);
  const PoseRefinementResult result = refiner.refine(&problem);
  ASSERT_TRUE(result.ran);
  const double error_after = meanImageMotionPx(scene_, problem.source_cameras[0], true_sources_[0]);
  std::cout << "weighed by size: mean image motion of the perturbed source 3.01 -> " << error_after << " px\n";
  EXPECT_EQ(result.sources[0].outcome, SourcePoseOutcome::kRefined);
  EXPECT_LT(error_after, 0.05);  // measured 0.025 px (unweighted: 0.011; the prior weighs relatively more)
  EXPECT_EQ(result.sources[1].outcome, SourcePoseOutcome::kConfirmed);
}

TEST_F(PoseRefinementScene, TexturelessSourceKeepsTheTrackersPoseAndSaysSo) {
  AMHMVS_REQUIRE_POSE_REFINEMENT();
  DepthProblem& problem = scene_.problem;
  const ImageU8 blank(problem.reference_camera.width, problem.reference_camera.height, 1, 128);
  problem.source_images[1] = blank;
  problem.source_cameras[1] = withPoseError(true_sources_[1], {0.01, 0, 0}, {0, 1, 0}, 0.3);
  const PinholeCamera tracker = problem.source_cameras[1];
  PoseRefiner refiner{PoseRefinementOptions()};
  const PoseRefinementResult result = refiner.refine(&problem);
  ASSERT_TRUE(result.ran);
  EXPECT_EQ(result.sources[1].outcome, SourcePoseOutcome::kTooFewMatches);
  EXPECT_EQ(result.sources[1].matches, 0);
  EXPECT_EQ(problem.source_cameras[1].R, tracker.R);
  EXPECT_EQ(problem.source_cameras[1].t, tracker.t);
  // The other source's pose is exact: the features confirm it.
  EXPECT_EQ(result.sources[0].outcome, SourcePoseOutcome::kConfirmed);
  EXPECT_EQ(result.refinedCount(), 0);
  EXPECT_EQ(problem.source_cameras[0].R, true_sources_[0].R);
  EXPECT_EQ(problem.source_cameras[0].t, true_sources_[0].t);
}

TEST_F(PoseRefinementScene, ImplausibleCorrectionIsRejectedAndCounted) {
  AMHMVS_REQUIRE_POSE_REFINEMENT();
  DepthProblem& problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.01, 0.01, 0}, {0, 1, 0}, 1.0);
  const PinholeCamera tracker = problem.source_cameras[0];
  PoseRefinementOptions options;
  options.max_correction_deg = 0.5;  // the error to remove is 1 degree
  PoseRefiner refiner(options);
  const PoseRefinementResult result = refiner.refine(&problem);
  EXPECT_EQ(result.sources[0].outcome, SourcePoseOutcome::kRejected);
  EXPECT_EQ(result.rejectedCount(), 1);
  EXPECT_EQ(problem.source_cameras[0].R, tracker.R);
  EXPECT_EQ(problem.source_cameras[0].t, tracker.t);
  // The exact source, solved again without the rejected one, is confirmed.
  EXPECT_EQ(result.sources[1].outcome, SourcePoseOutcome::kConfirmed);
  EXPECT_EQ(meanImageMotionPx(scene_, problem.source_cameras[1], true_sources_[1]), 0);
}

TEST_F(PoseRefinementScene, FeaturesAreDetectedOncePerImageKey) {
  AMHMVS_REQUIRE_POSE_REFINEMENT();
  DepthProblem& problem = scene_.problem;
  problem.reference_key = 10;
  problem.source_keys = {11, 12};
  PoseRefiner refiner{PoseRefinementOptions()};
  EXPECT_GT(refiner.refine(&problem).feature_ms, 0);
  EXPECT_EQ(refiner.cachedImages(), 3u);
  EXPECT_EQ(refiner.refine(&problem).feature_ms, 0);  // all three cached
  refiner.forget(12);
  EXPECT_EQ(refiner.cachedImages(), 2u);
  EXPECT_GT(refiner.refine(&problem).feature_ms, 0);
  refiner.forgetAll();
  EXPECT_EQ(refiner.cachedImages(), 0u);
}

TEST(PoseRefinement, BuildsWithoutItSayWhy) {
  if (PoseRefiner::available()) GTEST_SKIP() << "this build has the pose refinement";
  SyntheticProblem scene = makeSyntheticProblem(64, 48, 1);
  PoseRefiner refiner{PoseRefinementOptions()};
  const PoseRefinementResult result = refiner.refine(&scene.problem);
  EXPECT_FALSE(result.ran);
  EXPECT_NE(result.note.find("OpenCV features2d and Ceres"), std::string::npos) << result.note;
}

TEST(PoseRefinementOptions, DefaultsAreValidAndBadValuesNamed) {
  EXPECT_EQ(PoseRefinementOptions().validate(), "");
  const std::vector<std::pair<void (*)(PoseRefinementOptions&), std::string>> bad = {
      {[](PoseRefinementOptions& o) { o.max_features = 4; }, "max_features"},
      {[](PoseRefinementOptions& o) { o.ratio_test = 1.5; }, "ratio_test"},
      {[](PoseRefinementOptions& o) { o.inlier_threshold_px = 0; }, "inlier_threshold_px"},
      {[](PoseRefinementOptions& o) { o.min_inliers = 3; }, "min_inliers"},
      {[](PoseRefinementOptions& o) { o.feature_sigma_px = NAN; }, "feature_sigma_px"},
      {[](PoseRefinementOptions& o) { o.finest_feature_size_px = -1; }, "finest_feature_size_px"},
      {[](PoseRefinementOptions& o) { o.finest_feature_size_px = INFINITY; }, "finest_feature_size_px"},
      {[](PoseRefinementOptions& o) { o.prior_position_sigma_m = -1; }, "prior_position_sigma_m"},
      {[](PoseRefinementOptions& o) { o.prior_rotation_sigma_deg = 0; }, "prior_rotation_sigma_deg"},
      {[](PoseRefinementOptions& o) { o.max_iterations = 0; }, "max_iterations"},
      {[](PoseRefinementOptions& o) { o.max_correction_m = INFINITY; }, "max_correction_m"},
      {[](PoseRefinementOptions& o) { o.max_correction_deg = 200; }, "max_correction_deg"},
      {[](PoseRefinementOptions& o) { o.max_pose_reestimates = -1; }, "max_pose_reestimates"},
      {[](PoseRefinementOptions& o) { o.reestimate_length_change = 0; }, "reestimate_length_change"},
      {[](PoseRefinementOptions& o) { o.reestimate_length_change = NAN; }, "reestimate_length_change"},
  };
  for (const auto& [spoil, name] : bad) {
    PoseRefinementOptions options;
    spoil(options);
    const std::string problems = options.validate();
    EXPECT_EQ(problems.rfind(name + " must be", 0), 0u) << problems;
    try {
      PoseRefiner refiner(options);
      ADD_FAILURE() << name << ": no InputError";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

TEST(PoseRefinementOptions, TableSetsAndGetsEveryOption) {
  PoseRefinementOptions options;
  for (const PoseRefinementOptionInfo& option : poseRefinementOptionTable()) {
    // A switch to the opposite of its default, a number to 7.
    const std::string default_value = option.get(PoseRefinementOptions());
    const bool is_switch = default_value == "true" || default_value == "false";
    const std::string value = is_switch ? (default_value == "true" ? "false" : "true") : "7";
    option.set(options, value);
    EXPECT_EQ(option.get(options), value) << option.name;
  }
  EXPECT_NE(options, PoseRefinementOptions());
  EXPECT_THROW(poseRefinementOptionTable().front().set(options, "maybe"), InputError);
  EXPECT_THROW(poseRefinementOptionTable().back().set(options, "2x"), InputError);
}

}  // namespace
}  // namespace amhmvs
