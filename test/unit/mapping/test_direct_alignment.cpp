// Direct alignment of the sources before stereo (mapping/direct_alignment.h)
// on the folded planes (synthetic_problem.h): a known pose error of a source
// is removed, also across an exposure change; the per-point Jacobian agrees
// with finite differences; sources without depth or texture keep the
// tracker's pose and say why; bad input is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/direct_alignment.h"
#include "amhmvs_mapping/mapping/direct_alignment_pixel.h"
#include "pose_error.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

using test::withPoseError;

// The source's depth map as an earlier keyframe would have it: the true
// depth, every pixel confident.
DepthMap trueDepthOf(const PinholeCamera& camera) {
  DepthMap map;
  map.depth = renderView(makeFoldedPlanesWorld(1), camera, 1).depth;
  map.cost = ImageF(camera.width, camera.height, 1, 0.1f);
  return map;
}

class DirectAlignmentScene : public ::testing::Test {
 protected:
  // 320x240, reference and two sources 0.15 m apart, 2.5-4 m away.
  DirectAlignmentScene() : scene_(makeSyntheticProblem(320, 240, 2)) {
    true_sources_ = scene_.problem.source_cameras;
    for (const PinholeCamera& camera : true_sources_) depths_.push_back(trueDepthOf(camera));
  }
  double motionPx(const PinholeCamera& a, const PinholeCamera& b) const {
    return test::meanImageMotionPx(scene_.problem.reference_camera, scene_.true_depth, a, b);
  }
  std::vector<std::vector<Eigen::Vector3f>> surfaces() const {
    return {confidentDepthPoints(depths_[0], true_sources_[0], 0.5), confidentDepthPoints(depths_[1], true_sources_[1], 0.5)};
  }

  SyntheticProblem scene_;
  std::vector<PinholeCamera> true_sources_;
  std::vector<DepthMap> depths_;
};

TEST_F(DirectAlignmentScene, RemovesAKnownPoseErrorOfASource) {
  // 12 mm and 0.5 degrees: about 3 px at 320 px, a tracker's error.
  DepthProblem& problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const PinholeCamera reference_before = problem.reference_camera;
  const double before = motionPx(problem.source_cameras[0], true_sources_[0]);
  const DirectAlignmentResult result = alignSourcesDirectly(&problem, surfaces(), DirectAlignmentOptions());
  ASSERT_TRUE(result.ran);
  ASSERT_EQ(result.sources.size(), 2u);
  const double after = motionPx(problem.source_cameras[0], true_sources_[0]);
  const double exact_after = motionPx(problem.source_cameras[1], true_sources_[1]);
  const SourceAlignment& moved = result.sources[0];
  std::cout << "mean image motion of the perturbed source: " << before << " -> " << after << " px; the exact source "
            << exact_after << " px; " << moved.points << " points, RMS " << moved.rms_before_grey << " -> "
            << moved.rms_after_grey << " grey levels, " << result.total_ms << " ms\n";
  EXPECT_GT(before, 2.5);
  EXPECT_EQ(moved.outcome, SourceAlignmentOutcome::kAligned);
  EXPECT_LT(after, 0.1);
  EXPECT_LT(exact_after, 0.1);  // aligned or kept: either way where it was
  EXPECT_LT(moved.rms_after_grey, 0.5 * moved.rms_before_grey);
  // The reported image shift of the correction is the error it removed
  // (seen in the reference instead of the source, median instead of mean).
  const double shift = std::hypot(moved.shift_across_px, moved.shift_along_px);
  std::cout << "reported shift: " << moved.shift_across_px << " across, " << moved.shift_along_px << " along the lines\n";
  EXPECT_GT(shift, 0.7 * before);
  EXPECT_LT(shift, 1.3 * before);
  EXPECT_LT(std::hypot(result.sources[1].shift_across_px, result.sources[1].shift_along_px), 0.1);
  // Same exposure: mid-grey stays where it was (gain and offset trade off
  // over the image's range, so they are checked together).
  EXPECT_NEAR(moved.gain * 128 + moved.bias, 128, 1.0);
  EXPECT_TRUE(problem.reference_camera.R.isApprox(reference_before.R));
  EXPECT_TRUE(problem.reference_camera.t.isApprox(reference_before.t));
}

TEST_F(DirectAlignmentScene, AcrossEpipolarLinesOnlyLeavesTheMotionAlongThem) {
  DepthProblem& problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const auto across = [this](const PinholeCamera& camera) {
    return test::meanAcrossEpipolarPx(scene_.problem.reference_camera, scene_.true_depth, camera, true_sources_[0]);
  };
  const double across_before = across(problem.source_cameras[0]);
  DirectAlignmentOptions options;
  options.across_epipolar_only = true;
  const DirectAlignmentResult result = alignSourcesDirectly(&problem, surfaces(), options);
  const double across_after = across(problem.source_cameras[0]);
  const double motion_after = motionPx(problem.source_cameras[0], true_sources_[0]);
  std::cout << "across epipolar lines: " << across_before << " -> " << across_after << " px; all motion left "
            << motion_after << " px\n";
  EXPECT_EQ(result.sources[0].outcome, SourceAlignmentOutcome::kAligned);
  EXPECT_GT(across_before, 1.0);
  EXPECT_LT(across_after, 0.1);
  std::cout << "reported shift: " << result.sources[0].shift_across_px << " across, "
            << result.sources[0].shift_along_px << " along the lines\n";
  EXPECT_NEAR(result.sources[0].shift_across_px, across_before, 0.3 * across_before);
  // Along the lines the error is the tracker's still, unobserved (a depth
  // error would look the same).
  EXPECT_GT(motion_after, 0.1);
}

TEST_F(DirectAlignmentScene, AlignsAcrossAnExposureChange) {
  // The source exposed 1.25x brighter and offset, clipped at 255.
  ImageU8 image(true_sources_[0].width, true_sources_[0].height, 1);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      image.at(x, y) = static_cast<uint8_t>(
          std::min(255.0, std::round(1.25 * scene_.problem.source_images[0].at(x, y) - 10)));
  DepthProblem problem = scene_.problem;
  problem.source_images[0] = ImageViewU8(image);
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const double before = motionPx(problem.source_cameras[0], true_sources_[0]);
  const DirectAlignmentResult result = alignSourcesDirectly(&problem, surfaces(), DirectAlignmentOptions());
  const double after = motionPx(problem.source_cameras[0], true_sources_[0]);
  std::cout << "exposure x1.25 - 10: " << before << " -> " << after << " px; gain " << result.sources[0].gain
            << ", bias " << result.sources[0].bias << "\n";
  EXPECT_GT(before, 2.0);
  EXPECT_LT(after, 0.15);
  // reference = (source + 10) / 1.25: mid-grey 128 of the source is 110.4.
  EXPECT_NEAR(result.sources[0].gain * 128 + result.sources[0].bias, 110.4, 1.5);
}

// A smooth image as a function (its central differences are near its derivative).
struct SmoothImage {
  float operator()(float x, float y) const { return 120 + 60 * std::sin(0.05f * x) * std::cos(0.04f * y) + 0.2f * x; }
};

TEST(DirectAlignmentTerm, JacobianAgreesWithFiniteDifferences) {
  const mvs::AlignmentIntrinsics intrinsics{300, 300, 160, 120, 320, 240};
  mvs::AlignmentPoint point{mvs::make_vec3(0.3f, -0.2f, 2.5f), 90};
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t0(0.1, -0.05, 0.02);
  auto state = [](const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double a, double b) {
    mvs::AlignmentState s;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) s.rotation[3 * r + c] = static_cast<float>(R(r, c));
    s.translation = mvs::make_vec3(static_cast<float>(t.x()), static_cast<float>(t.y()), static_cast<float>(t.z()));
    s.log_gain = static_cast<float>(a);
    s.bias = static_cast<float>(b);
    s.across_epipolar = false;
    s.epipole = mvs::make_vec3(0, 0, 1);
    return s;
  };
  mvs::AlignmentTerm term;
  ASSERT_TRUE(mvs::alignmentTerm(point, state(R0, t0, 0.1, 5), intrinsics, SmoothImage(), &term));
  // The left increment: X' = exp(w) X + v, then a and b.
  for (int k = 0; k < mvs::kAlignmentParameters; ++k) {
    const double h = k < 6 ? 1e-3 : 1e-2;
    double residual[2];
    for (int side = 0; side < 2; ++side) {
      Eigen::Matrix<double, 8, 1> step = Eigen::Matrix<double, 8, 1>::Zero();
      step(k) = side == 0 ? h : -h;
      const Eigen::Vector3d w = step.segment<3>(3);
      const Eigen::Matrix3d turn =
          w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
      mvs::AlignmentTerm moved;
      ASSERT_TRUE(mvs::alignmentTerm(point, state(turn * R0, turn * t0 + step.segment<3>(0), 0.1 + step(6), 5 + step(7)),
                                     intrinsics, SmoothImage(), &moved));
      residual[side] = moved.residual;
    }
    const double numeric = (residual[0] - residual[1]) / (2 * h);
    EXPECT_NEAR(term.jacobian[k], numeric, 0.02 * std::abs(numeric) + 0.05) << "parameter " << k;
  }
  // Behind the camera or outside the image: no term.
  point.point = mvs::make_vec3(0, 0, -1);
  EXPECT_FALSE(mvs::alignmentTerm(point, state(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 0, 0),
                                  intrinsics, SmoothImage(), &term));
  point.point = mvs::make_vec3(2, 0, 1);
  EXPECT_FALSE(mvs::alignmentTerm(point, state(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 0, 0),
                                  intrinsics, SmoothImage(), &term));
}

TEST_F(DirectAlignmentScene, SourcesWithoutDepthOrTextureKeepTheTrackersPose) {
  DepthProblem problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const PinholeCamera tracker = problem.source_cameras[0];
  // No depth map for source 0; a flat grey image for source 1.
  ImageU8 flat(true_sources_[1].width, true_sources_[1].height, 1, 128);
  problem.source_images[1] = ImageViewU8(flat);
  const DirectAlignmentResult result = alignSourcesDirectly(&problem, {{}, surfaces()[1]}, DirectAlignmentOptions());
  EXPECT_EQ(result.sources[0].outcome, SourceAlignmentOutcome::kNoDepth);
  EXPECT_EQ(result.sources[1].outcome, SourceAlignmentOutcome::kTooFewPoints);
  EXPECT_EQ(result.alignedCount(), 0);
  EXPECT_TRUE(problem.source_cameras[0].R.isApprox(tracker.R));
  EXPECT_TRUE(problem.source_cameras[1].t.isApprox(true_sources_[1].t));
}

TEST_F(DirectAlignmentScene, ImplausibleCorrectionsAreRejected) {
  DepthProblem problem = scene_.problem;
  problem.source_cameras[0] = withPoseError(true_sources_[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const PinholeCamera tracker = problem.source_cameras[0];
  DirectAlignmentOptions options;
  options.max_correction_deg = 0.1;  // the error is 0.5 deg
  const DirectAlignmentResult result = alignSourcesDirectly(&problem, surfaces(), options);
  EXPECT_EQ(result.sources[0].outcome, SourceAlignmentOutcome::kRejected);
  EXPECT_GT(result.sources[0].correction_deg, 0.3);
  EXPECT_TRUE(problem.source_cameras[0].R.isApprox(tracker.R));
}

TEST_F(DirectAlignmentScene, BadInputIsRefusedByName) {
  DepthProblem problem = scene_.problem;
  DirectAlignmentOptions options;
  options.huber_grey = -1;
  try {
    alignSourcesDirectly(&problem, surfaces(), options);
    FAIL() << "negative huber_grey accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("huber_grey must be finite and > 0 (got -1)"), std::string::npos) << e.what();
  }
  try {
    alignSourcesDirectly(&problem, {surfaces()[0]}, DirectAlignmentOptions());
    FAIL() << "one depth map for two sources accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1 source surfaces for 2 sources"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amhmvs
