// The parts of amhmvs_map below its command line: keyframe picking by
// motion and option parsing (its writer thread is the core's
// BackgroundWriter, tested on its own).
#include <gtest/gtest.h>

#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "keyframe_picker.h"
#include "map_options.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// Frames along x, 1 cm apart, turning 1 degree per frame about y from frame 20 on.
std::vector<PosedFrame> walkingFrames(int count) {
  std::vector<PosedFrame> frames(count);
  for (int i = 0; i < count; ++i) {
    frames[i].id = i;
    frames[i].camera = test::centredCamera(64, 48, 50);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(i < 20 ? 0.01 * i : 0.2, 0, 0);
    if (i >= 20) pose.linear() = Eigen::AngleAxisd((i - 20) * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    setCameraToWorld(pose, &frames[i].camera);
  }
  return frames;
}

TEST(MapTool, PicksKeyframesByTranslationAndRotation) {
  const std::vector<PosedFrame> frames = walkingFrames(40);
  FrameSelection selection;  // thresholds between the steps (no ties to round)
  selection.picking.min_translation_m = 0.045;
  selection.picking.min_rotation_deg = 4.5;
  selection.picking.min_relative_sharpness = 0;  // the frames have no images
  // Frames 20-39 turn in place: refused as pure rotations by default.
  PickedKeyframes picked = pickKeyframes(frames, selection);
  EXPECT_EQ(picked.indices, (std::vector<size_t>{0, 5, 10, 15, 20}));
  EXPECT_EQ(picked.stats.refused_pure_rotation, 15u);  // 25..39: each turned >= 4.5 deg from frame 20
  selection.picking.min_turning_translation_fraction = 0;
  picked = pickKeyframes(frames, selection);
  // 0, 5, 10, 15, 20 by translation (5 cm), then 25, 30, 35 by rotation (5 deg).
  EXPECT_EQ(picked.indices, (std::vector<size_t>{0, 5, 10, 15, 20, 25, 30, 35}));
  EXPECT_EQ(picked.stats.refused_pure_rotation, 0u);
  selection.picking.min_rotation_deg = 0;
  EXPECT_EQ(pickKeyframes(frames, selection).indices, (std::vector<size_t>{0, 5, 10, 15, 20}));
  selection.picking.min_translation_m = 0;
  EXPECT_EQ(pickKeyframes(frames, selection).indices.size(), 40u);  // both 0: every frame
  selection.start = 3;
  selection.stride = 4;
  selection.count = 5;
  EXPECT_EQ(pickKeyframes(frames, selection).indices, (std::vector<size_t>{3, 7, 11, 15, 19}));
  selection.start = 40;
  EXPECT_TRUE(pickKeyframes(frames, selection).indices.empty());
}

// The blur check's decoded images go to makeKeyframe (each picked image is
// decoded once per run): the keyframes are those of reading the files.
TEST(MapTool, KeyframesUseTheImagesTheBlurCheckDecoded) {
  test::TempDir dir;
  std::vector<PosedFrame> frames = walkingFrames(12);
  for (PosedFrame& frame : frames) {
    ImageU8 image(64, 48, 3);
    for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = static_cast<uint8_t>((i * 37 + frame.id * 11) % 251);
    frame.image_path = dir.path() + "/frame" + std::to_string(frame.id) + ".png";
    writePng(frame.image_path, image);
  }
  FrameSelection selection;
  selection.picking.min_translation_m = 0.045;
  PickedKeyframes picked = pickKeyframes(frames, selection);
  ASSERT_EQ(picked.indices, (std::vector<size_t>{0, 5, 10}));
  ASSERT_EQ(picked.decoded.size(), 3u);  // the picked frames only
  MapToolOptions options;
  options.max_image_size = 32;
  for (size_t index : picked.indices) {
    const Keyframe from_file = makeKeyframe(frames[index], options);
    const Keyframe handed_over = makeKeyframe(frames[index], options, picked.takeDecoded(index));
    EXPECT_EQ(handed_over.image.data, from_file.image.data) << index;
    EXPECT_EQ(handed_over.image.width, 32);
    EXPECT_EQ(handed_over.camera.fx, from_file.camera.fx);
  }
  EXPECT_TRUE(picked.decoded.empty());
  EXPECT_TRUE(picked.takeDecoded(0).empty());
  // Without the blur check nothing is decoded while picking.
  selection.picking.min_relative_sharpness = 0;
  EXPECT_TRUE(pickKeyframes(frames, selection).decoded.empty());
}

TEST(MapTool, ParsesOptionsAndRefusesBadOnes) {
  const MapToolOptions options = parseMapToolArguments(
      {"--backend", "cpu", "--max_image_size=256", "--num_sources", "4", "--iterations", "3", "--count", "20",
       "--stride", "2", "--keyframe_min_translation", "0.1", "--voxel_size", "0.05", "--intrinsics",
       "fitted7scenes", "--color_offset=-0.010,0,0", "--write_previews", "--write_clouds=0", "--depth_min",
       "0.5", "--depth_max", "4"});
  EXPECT_EQ(options.pipeline.backend, Backend::kCpu);
  EXPECT_EQ(options.max_image_size, 256);
  EXPECT_EQ(options.pipeline.mapper.sources.max_sources, 4);
  EXPECT_EQ(options.pipeline.estimator.num_iterations, 3);
  EXPECT_EQ(options.frames.count, 20u);
  EXPECT_EQ(options.frames.stride, 2u);
  EXPECT_EQ(options.frames.picking.min_translation_m, 0.1);
  EXPECT_EQ(options.pipeline.mapper.map.leaf_size, 0.05);
  EXPECT_EQ(options.sequence.color_intrinsics.fx, 528);
  EXPECT_EQ(options.sequence.color_offset.x(), -0.010);
  EXPECT_TRUE(options.write_previews);
  EXPECT_FALSE(options.write_clouds);
  EXPECT_TRUE(options.write_depth);
  EXPECT_EQ(options.depth_max, 4);
  // Queue: offline holds every keyframe; realtime the default the nodelet runs.
  EXPECT_EQ(resolvedQueueSize(options, 17), 17u);
  MapToolOptions realtime = options;
  realtime.realtime_rate = 1;
  EXPECT_EQ(resolvedQueueSize(realtime, 17), MappingParameters().pipeline.queue_size);  // the nodelet's 32
  realtime.queue_size = 2;
  EXPECT_EQ(resolvedQueueSize(realtime, 17), 2u);
  EXPECT_TRUE(options.pipeline.skip_to_newest);
  EXPECT_FALSE(parseMapToolArguments({"--skip_to_newest=0"}).pipeline.skip_to_newest);

  EXPECT_INPUT_ERROR(parseMapToolArguments({"--bogus", "1"}), "unknown option", "--bogus");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--count", "x"}), "--count", "'x'");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--stride", "0"}), "stride", ">= 1");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--depth_min", "2"}), "depth_min", "depth_max");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--color_offset", "1,2"}), "--color_offset", "x,y,z");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--write_depth=maybe"}), "--write_depth", "maybe");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--iterations", "0"}), "iterations", "1..100");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--voxel_size"}), "--voxel_size", "needs a value");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"stray"}), "unexpected argument", "stray");
}

TEST(MapTool, PoseRefinementOptions) {
  EXPECT_FALSE(parseMapToolArguments({}).pipeline.mapper.pose_refinement.enabled);  // off by default
  EXPECT_EQ(parseMapToolArguments({"--pose_refinement_max_features", "500"}).pipeline.mapper.pose_refinement.max_features,
            500);
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--pose_refinement_min_inliers", "3"}), "pose_refinement: min_inliers",
                     ">= 6");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--pose_refinement_ratio_test", "x"}), "ratio_test", "'x'");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--pose_refinement_bogus", "1"}), "unknown option",
                     "--pose_refinement_bogus");
  if (PoseRefiner::available()) {
    EXPECT_TRUE(parseMapToolArguments({"--pose_refinement"}).pipeline.mapper.pose_refinement.enabled);
  } else {  // asked for in a build without it: a clear error, not a silent run without
    EXPECT_INPUT_ERROR(parseMapToolArguments({"--pose_refinement"}), "--pose_refinement",
                       "OpenCV features2d and Ceres");
  }
}

TEST(MapTool, ParsesTheLowTextureAndNeighbourDepthSwitches) {
  const MapToolOptions defaults = parseMapToolArguments({});
  // The product's two scales (the paper's single scale is PatchMatchOptions' own default).
  EXPECT_EQ(defaults.pipeline.estimator.multiscale_levels, 2);
  EXPECT_EQ(defaults.pipeline.estimator.multiscale_iterations, 1);
  EXPECT_EQ(PatchMatchOptions().multiscale_levels, 1);
  EXPECT_EQ(defaults.pipeline.mapper.neighbour_depth.start_from_neighbours, NeighbourDepthOptions::Start::kAuto);
  EXPECT_FALSE(defaults.pipeline.mapper.neighbour_depth.geometric_refinement);
  const MapToolOptions options = parseMapToolArguments(
      {"--multiscale", "3", "--multiscale_iterations=2", "--start_from_neighbours", "--start_iterations", "3",
       "--start_max_cost", "0.4", "--geometric_refinement=1", "--geometric_refinement_iterations", "2"});
  EXPECT_EQ(options.pipeline.estimator.multiscale_levels, 3);
  EXPECT_EQ(options.pipeline.estimator.multiscale_iterations, 2);
  const NeighbourDepthOptions& neighbours = options.pipeline.mapper.neighbour_depth;
  EXPECT_EQ(neighbours.start_from_neighbours, NeighbourDepthOptions::Start::kOn);
  EXPECT_EQ(neighbours.start_iterations, 3);
  EXPECT_EQ(neighbours.start_max_cost, 0.4);
  EXPECT_TRUE(neighbours.geometric_refinement);
  EXPECT_EQ(neighbours.geometric_iterations, 2);
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--multiscale", "9"}), "multiscale", "1..6");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--start_iterations", "-2"}), "start_iterations", "0..100");
  EXPECT_INPUT_ERROR(parseMapToolArguments({"--geometric_refinement_iterations", "0"}), "geometric_iterations",
                     "1..100");
}

}  // namespace
}  // namespace amhmvs
