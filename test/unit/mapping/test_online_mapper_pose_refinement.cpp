// OnlineMapper with pose refinement (pose_refinement.h) on the folded planes:
// the estimator gets refined source cameras, while the depth map, the stored
// keyframes, the fused clouds and the map keep the tracker's poses.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/simulation/realistic_capture.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "pose_error.h"
#include "test_helpers.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

using test::meanImageMotionPx;

TEST(OnlineMapperPoseRefinement, EstimatorSeesRefinedSourcesEverythingElseTheTrackersPoses) {
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage();
  // Two views of the folds 0.15 m apart; the tracker is 12 mm and 0.5 degrees
  // off for keyframe 0 and exact for keyframe 1.
  const SyntheticWorld world = makeFoldedPlanesWorld(1);
  const std::vector<PinholeCamera> truth = makeSidewaysCameras(2, 320, 240);
  std::map<int64_t, RenderedView> views;
  std::vector<Keyframe> keyframes;
  for (int64_t id = 0; id < 2; ++id) {
    views[id] = renderView(world, truth[id]);
    Keyframe keyframe;
    keyframe.id = id;
    keyframe.stamp = static_cast<double>(id);
    keyframe.image = views[id].image;
    keyframe.camera = truth[id];
    keyframes.push_back(keyframe);
  }
  keyframes[0].camera = test::withPoseError(truth[0], {0.004, -0.008, 0.008}, {1, 2, 0.5}, 0.5);
  const std::vector<PinholeCamera> tracker = {keyframes[0].camera, keyframes[1].camera};

  OnlineMapperOptions options;
  options.pose_refinement.enabled = true;
  options.fusion.min_consistent_views = 1;
  options.map_in_background = false;
  std::map<int64_t, DepthProblem> problems;  // what the estimator saw, by reference keyframe
  OnlineMapper mapper(options, [&](const DepthProblem& problem) {
    problems[problem.reference_key] = problem;
    DepthMap map;  // the view's true depth
    map.depth = views.at(problem.reference_key).depth;
    map.normal = views.at(problem.reference_key).normal;
    map.cost = ImageF(map.depth.width, map.depth.height, 1, 0.1f);
    return map;
  });
  mapper.process(keyframes[0]);  // no source yet
  const KeyframeResult second = mapper.process(keyframes[1]);
  KeyframeResult first;
  ASSERT_TRUE(mapper.estimateLate(&first));

  // Keyframe 1's estimate: its own camera is the tracker's, its source's is refined.
  ASSERT_TRUE(second.has_depth);
  ASSERT_TRUE(second.pose_refinement.ran);
  EXPECT_EQ(second.pose_refinement.refinedCount(), 1);
  const DepthProblem& seen = problems.at(1);
  EXPECT_EQ(seen.reference_camera.R, tracker[1].R);
  EXPECT_EQ(seen.reference_camera.t, tracker[1].t);
  const double before = meanImageMotionPx(truth[1], views[1].depth, tracker[0], truth[0]);
  const double after = meanImageMotionPx(truth[1], views[1].depth, seen.source_cameras[0], truth[0]);
  std::cout << "keyframe 1's source: " << before << " -> " << after << " px from its true camera\n";
  // Measured 3.00 -> 0.31 px: with one source what is left is most of the
  // 4 mm error along the baseline (the scale, which the features cannot see;
  // the prior fits it to both keyframes' tracker poses).
  EXPECT_GT(before, 2.5);
  EXPECT_LT(after, 0.4);
  // Keyframe 0's late estimate: its own camera is the tracker's (12 mm off),
  // its source (keyframe 1) is moved to agree with it.
  ASSERT_TRUE(first.pose_refinement.ran);
  EXPECT_EQ(problems.at(0).reference_camera.R, tracker[0].R);
  EXPECT_EQ(problems.at(0).reference_camera.t, tracker[0].t);
  EXPECT_GT((problems.at(0).source_cameras[0].center() - tracker[1].center()).norm(), 0.005);

  // Results, store, clouds and map: the tracker's poses.
  EXPECT_EQ(second.camera.t, tracker[1].t);
  EXPECT_EQ(first.camera.t, tracker[0].t);
  for (int64_t id = 0; id < 2; ++id) {
    EXPECT_EQ(mapper.store().keyframe(id).camera.R, tracker[id].R);
    EXPECT_EQ(mapper.store().keyframe(id).camera.t, tracker[id].t);
  }
  ASSERT_FALSE(first.fused.empty());
  for (const FusedKeyframe& fused : first.fused) {
    EXPECT_EQ(fused.camera.t, tracker[fused.id].t);
    EXPECT_FALSE(fused.points->empty());
    EXPECT_TRUE(mapper.map().pose(fused.id).isApprox(cameraToWorld(tracker[fused.id])));
  }
}

// A camera that slides past the folds while it turns at a constant rate (so
// the true poses' chords are exact), taken by a rolling shutter with a long
// readout (so that the turn rate's error shows in the images); the
// tracker's poses are 0.4 deg off, which turns their chords by about 1.4
// deg/s.
struct TurningSlide {
  Eigen::Vector3d turn_rate{0.03, -0.12, 0.02}, velocity{0.3, 0, 0};  // camera frame: rad/s, m/s
  double readout_s = 0.1;
  std::map<int64_t, RenderedView> views;  // what each keyframe's camera took
  std::map<int64_t, ImageU8> global;      // a global shutter at its middle row's pose
  std::vector<Keyframe> keyframes;
};

TurningSlide makeTurningSlide() {
  TurningSlide slide;
  const SyntheticWorld world = makeFoldedPlanesWorld(1);
  const PinholeCamera start = makeSidewaysCameras(1, 320, 240)[0];
  const auto cameraAt = [&](double seconds) {
    Eigen::Isometry3d pose = cameraToWorld(start);
    pose.translation() += pose.linear() * slide.velocity * seconds;
    pose.linear() = pose.linear() *
                    Eigen::AngleAxisd(slide.turn_rate.norm() * seconds, slide.turn_rate.normalized()).matrix();
    PinholeCamera camera = start;
    setCameraToWorld(pose, &camera);
    return camera;
  };
  RealismOptions rolling;
  rolling.rolling_shutter_s = slide.readout_s;
  const std::vector<Eigen::Vector3d> error_axes = {{1, 2, 0.5}, {-2, 1, 1}, {0.5, -1, 2}};
  for (int64_t id = 0; id < 3; ++id) {
    const double stamp = 0.5 * static_cast<double>(id);
    const CameraTrajectory trajectory = [&](int, double seconds) { return cameraAt(stamp + seconds); };
    slide.views[id] = renderRealisticView(world, trajectory, 0, rolling, {});
    slide.global[id] = renderView(world, cameraAt(stamp)).image;
    Keyframe keyframe;
    keyframe.id = id;
    keyframe.stamp = stamp;
    keyframe.image = slide.views[id].image;
    keyframe.camera = test::withPoseError(cameraAt(stamp), {0.002 * id, -0.003, 0.002}, error_axes[id], 0.4);
    slide.keyframes.push_back(keyframe);
  }
  return slide;
}

// Per keyframe, the reference pixels its last estimate read.
using SeenImages = std::map<int64_t, std::vector<uint8_t>>;
struct SlideRun {
  std::unique_ptr<OnlineMapper> mapper;
  std::shared_ptr<std::vector<int64_t>> forgotten =  // images the estimator was told to forget
      std::make_shared<std::vector<int64_t>>();
};

// The slide through a mapper with pose refinement and the keyframe bundle
// adjustment, depth maps taken from the renderer.
SlideRun runSlide(const TurningSlide& slide, const RollingShutterOptions& rolling_shutter, SeenImages* seen) {
  OnlineMapperOptions options;
  options.pose_refinement.enabled = true;
  options.pose_refinement.keyframe_bundle_adjustment = true;
  options.rolling_shutter = rolling_shutter;
  options.fusion.min_consistent_views = 1;
  options.map_in_background = false;
  SlideRun run;
  run.mapper = std::make_unique<OnlineMapper>(options, [&slide, seen](const DepthProblem& problem) {
    const ImageViewU8& image = problem.reference_image;
    (*seen)[problem.reference_key].assign(image.data, image.data + image.width * image.height * image.channels);
    DepthMap map;
    map.depth = slide.views.at(problem.reference_key).depth;
    map.normal = slide.views.at(problem.reference_key).normal;
    map.cost = ImageF(map.depth.width, map.depth.height, 1, 0.1f);
    return map;
  });
  run.mapper->setForgetImageFunction([forgotten = run.forgotten](int64_t id) { forgotten->push_back(id); });
  for (const Keyframe& keyframe : slide.keyframes) run.mapper->process(keyframe);
  KeyframeResult result;
  while (run.mapper->estimateLate(&result) || run.mapper->refine(&result)) {
  }
  return run;
}

// Rolling shutter with the keyframe bundle adjustment: each keyframe is
// rectified at first with the chord of the tracker's poses, then again with
// the turn rate of the adjusted poses around it, and estimated again from the
// new images.
TEST(OnlineMapperPoseRefinement, RollingShutterRectifiedAgainFromTheAdjustedPoses) {
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage();
  const TurningSlide slide = makeTurningSlide();
  using test::meanDifference;
  RollingShutterOptions rolling_shutter;
  rolling_shutter.readout_s = slide.readout_s;
  SeenImages chord_seen, again_seen;
  const SlideRun chords = runSlide(slide, rolling_shutter, &chord_seen);
  rolling_shutter.from_adjusted_poses = true;
  const SlideRun again = runSlide(slide, rolling_shutter, &again_seen);
  EXPECT_EQ(chords.mapper->rollingShutterRectifiedAgain(), 0u);
  EXPECT_GE(again.mapper->rollingShutterRectifiedAgain(), 3u);
  EXPECT_EQ(again.forgotten->size(), again.mapper->rollingShutterRectifiedAgain());  // each told to the estimator
  for (int64_t id = 0; id < 3; ++id) {
    // The image rectified with the true turn rate (a global shutter's, up to
    // the resampling and the slide during the readout).
    const ImageU8 right =
        rectifyRollingShutter(slide.views.at(id).image, slide.keyframes[id].camera, slide.turn_rate, slide.readout_s);
    const double chord_off = meanDifference(chords.mapper->store().keyframe(id).image, right);
    const double again_off = meanDifference(again.mapper->store().keyframe(id).image, right);
    std::printf("keyframe %d: grey levels from the image rectified with the true turn rate: rectified from the "
                "chords %.3f, again %.3f (global shutter's image: %.3f as taken, %.3f rectified right)\n",
                static_cast<int>(id), chord_off, again_off, meanDifference(slide.views.at(id).image, slide.global.at(id)),
                meanDifference(right, slide.global.at(id)));
    // Measured: 1.48-1.56 grey levels from the chords, 0.05-0.09 again.
    EXPECT_LT(again_off, 0.15 * chord_off);
    // The last estimate of every keyframe read its image as rectified again.
    ASSERT_TRUE(again_seen.count(id));
    EXPECT_EQ(again_seen.at(id), again.mapper->store().entry(id).grayImage().data);
  }
}

// The tracker's velocity comes with each keyframe, its turn rate 1.7 deg/s
// off: with its noise given (rolling_shutter.tracker_velocity_sigma_*), the
// keyframe bundle adjustment solves each keyframe's velocity, the image is
// rectified again with the solved turn rate and its rows' centres move with
// the solved velocity, and the depth maps are estimated again from them.
// This checks that path; what the solve finds is KeyframeBundleAdjustment's
// test and the realism room's CLI test. Here, three keyframes of two folded
// planes, the images do not tell the turn rate (a row's turn trades with the
// slide and the poses): measured 1.81-1.83 grey levels from the true
// rectification with the tracker's rate, 1.52-2.29 solved; the adjusted
// poses' chords (test above) see it better in such a scene.
TEST(OnlineMapperPoseRefinement, TrackersVelocitySolvedAndTheImagesRectifiedAgain) {
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage();
  TurningSlide slide = makeTurningSlide();
  const Eigen::Vector3d turn_error(0.01, 0.025, -0.01), velocity_error(0.05, -0.05, 0.02);
  for (Keyframe& keyframe : slide.keyframes) keyframe.velocity = CameraVelocity{slide.turn_rate + turn_error, slide.velocity + velocity_error};
  using test::meanDifference;
  RollingShutterOptions rolling_shutter;
  rolling_shutter.readout_s = slide.readout_s;
  rolling_shutter.use_tracker_velocity = true;
  SeenImages given_seen, solved_seen;
  const SlideRun given = runSlide(slide, rolling_shutter, &given_seen);
  rolling_shutter.tracker_velocity_sigma_rad_s = 0.05;
  rolling_shutter.tracker_velocity_sigma_m_s = 0.1;
  const SlideRun solved = runSlide(slide, rolling_shutter, &solved_seen);
  EXPECT_EQ(given.mapper->rollingShutterRectifiedAgain(), 0u);
  EXPECT_GE(solved.mapper->rollingShutterRectifiedAgain(), 3u);
  EXPECT_EQ(solved.forgotten->size(), solved.mapper->rollingShutterRectifiedAgain());
  for (int64_t id = 0; id < 3; ++id) {
    const ImageU8 right =
        rectifyRollingShutter(slide.views.at(id).image, slide.keyframes[id].camera, slide.turn_rate, slide.readout_s);
    const double given_off = meanDifference(given.mapper->store().keyframe(id).image, right);
    const double solved_off = meanDifference(solved.mapper->store().keyframe(id).image, right);
    const Eigen::Vector3d moved = solved.mapper->store().entry(id).motion.velocity;
    std::printf("keyframe %d: grey levels from the image rectified with the true turn rate: with the tracker's "
                "%.3f, solved %.3f; rows' velocity %.3f m/s from the true (tracker's: %.3f)\n",
                static_cast<int>(id), given_off, solved_off, (moved - slide.velocity).norm(), velocity_error.norm());
    EXPECT_GT(meanDifference(solved.mapper->store().keyframe(id).image, given.mapper->store().keyframe(id).image),
              0.05);  // rectified again
    EXPECT_TRUE(given.mapper->store().entry(id).motion.velocity.isApprox(slide.velocity + velocity_error));
    EXPECT_FALSE(moved.isApprox(slide.velocity + velocity_error));  // the solved one
    ASSERT_TRUE(solved_seen.count(id));
    EXPECT_EQ(solved_seen.at(id), solved.mapper->store().entry(id).grayImage().data);
  }
}

TEST(OnlineMapperPoseRefinement, OptionsAreCheckedAndTheSwitchTurnsItOff) {
  OnlineMapperOptions options;
  options.pose_refinement.min_inliers = 2;
  EXPECT_NE(options.validate().find("pose_refinement: min_inliers"), std::string::npos) << options.validate();
  options = OnlineMapperOptions();
  options.pose_refinement.enabled = false;
  OnlineMapper mapper(options, [](const DepthProblem& problem) {
    DepthMap map;
    map.depth = ImageF(problem.reference_camera.width, problem.reference_camera.height, 1, 3.0f);
    return map;
  });
  SyntheticProblem scene = makeSyntheticProblem(64, 48, 1);
  for (int64_t id = 0; id < 2; ++id) {
    Keyframe keyframe;
    keyframe.id = id;
    keyframe.stamp = static_cast<double>(id);
    const ImageViewU8 image = id == 0 ? scene.problem.source_images[0] : scene.problem.reference_image;
    keyframe.image = ImageU8(image.width, image.height, 1);
    std::copy(image.data, image.data + image.width * image.height, keyframe.image.data.begin());
    keyframe.camera = id == 0 ? scene.problem.source_cameras[0] : scene.problem.reference_camera;
    const KeyframeResult result = mapper.process(keyframe);
    EXPECT_FALSE(result.pose_refinement.ran);
    EXPECT_EQ(result.times.pose_refinement_ms, 0);
  }
}

TEST(OnlineMapperPoseRefinement, PipelineWarnsWhenAskedForItInABuildWithoutIt) {
  PipelineOptions options;
  options.mapper.pose_refinement.enabled = true;
  std::vector<std::string> warnings;
  MappingPipeline pipeline(options, [](const DepthProblem& problem) {
    DepthMap map;
    map.depth = ImageF(problem.reference_camera.width, problem.reference_camera.height, 1, 3.0f);
    return map;
  }, nullptr, "injected", [&warnings](MappingPipeline::LogLevel level, const std::string& line) {
    if (level == MappingPipeline::LogLevel::kWarn) warnings.push_back(line);
  });
  if (PoseRefiner::available()) {
    EXPECT_TRUE(warnings.empty()) << warnings.front();
  } else {
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("no pose refinement: it needs OpenCV features2d and Ceres"), std::string::npos)
        << warnings[0];
  }
}

}  // namespace
}  // namespace amhmvs
