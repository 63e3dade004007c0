// The online mapper's use of the neighbours' depth maps
// (mapping/neighbour_depth.h): what the estimator is given, with an injected
// estimator that returns the exact depth of a wall.
#include "amhmvs_mapping/mapping/neighbour_depth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "amhmvs_mapping/mapping/online_mapper.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

using test::keyframeAt;
using test::kWallZ;
using test::wallDepth;
using test::wallOptions;

// What one estimate call was given.
struct Given {
  bool prior = false;
  int prior_iterations = 0;
  size_t prior_pixels = 0, prior_pixels_on_wall = 0;
  std::vector<bool> source_depths;  // per source: has a depth map
};

Given inspect(const DepthProblem& problem) {
  Given given;
  given.prior = problem.prior_depth.data != nullptr;
  given.prior_iterations = problem.prior_iterations;
  const double wall = kWallZ - cameraToWorld(problem.reference_camera).translation().z();
  for (size_t i = 0; given.prior && i < problem.prior_depth.pixelCount(); ++i) {
    const float depth = problem.prior_depth.data[i];
    if (!(depth > 0.0f)) continue;
    ++given.prior_pixels;
    const bool facing = std::abs(problem.prior_normal.data[3 * i + 2] + 1.0f) < 1e-5f;
    given.prior_pixels_on_wall += std::abs(depth - wall) < 1e-5 * wall && facing;
  }
  for (const ImageViewF& depth : problem.source_depths) given.source_depths.push_back(depth.data != nullptr);
  return given;
}

// A mapper whose estimates record what they were given.
struct RecordingMapper {
  explicit RecordingMapper(const OnlineMapperOptions& options)
      : mapper(options, [this](const DepthProblem& problem) {
          calls.push_back(inspect(problem));
          return wallDepth(problem);
        }) {}
  // Keyframes 0, 1 (from 0, which has no depth map yet), 0 late (from 1),
  // 2 (from 0 and 1): three first estimates.
  void estimateThreeKeyframes() {
    KeyframeResult result;
    mapper.process(keyframeAt(0, 0.0));
    mapper.process(keyframeAt(1, 0.5));
    ASSERT_TRUE(mapper.estimateLate(&result));
    mapper.process(keyframeAt(2, 1.0));
    ASSERT_EQ(calls.size(), 3u);
  }
  std::vector<Given> calls;
  OnlineMapper mapper;
};

// By default (auto) a first estimate starts from the neighbours with the CPU
// estimator and not with CUDA; switched off it never does; a refinement
// never does, and gets no depth maps without the geometric refinement.
TEST(NeighbourDepth, ByDefaultOnlyTheCpuEstimatorStartsFromTheNeighbours) {
  struct Case {
    NeighbourDepthOptions::Start start;
    bool on_gpu;
    bool expect_prior;
  };
  for (const Case& c : {Case{NeighbourDepthOptions::Start::kAuto, false, true},
                        Case{NeighbourDepthOptions::Start::kAuto, true, false},
                        Case{NeighbourDepthOptions::Start::kOff, false, false},
                        Case{NeighbourDepthOptions::Start::kOn, true, true}}) {
    SCOPED_TRACE(std::string(neighbourStartName(c.start)) + (c.on_gpu ? " on CUDA" : " on the CPU"));
    OnlineMapperOptions options = wallOptions();
    EXPECT_EQ(options.neighbour_depth.start_from_neighbours, NeighbourDepthOptions::Start::kAuto);
    options.neighbour_depth.start_from_neighbours = c.start;
    options.neighbour_depth.on_gpu = c.on_gpu;
    RecordingMapper recording(options);
    recording.estimateThreeKeyframes();
    KeyframeResult result;
    ASSERT_TRUE(recording.mapper.refine(&result));
    ASSERT_EQ(recording.calls.size(), 4u);
    EXPECT_FALSE(recording.calls[0].prior);  // its source has no depth map yet
    for (size_t i = 1; i < 3; ++i) {
      EXPECT_EQ(recording.calls[i].prior, c.expect_prior) << i;
      if (c.expect_prior) EXPECT_EQ(recording.calls[i].prior_iterations, 2) << i;
    }
    EXPECT_FALSE(recording.calls[3].prior);  // the refinement
    for (const Given& given : recording.calls) EXPECT_TRUE(given.source_depths.empty());
  }
}

TEST(NeighbourDepth, TheStartSwitchReadsTrueFalseAndAuto) {
  using Start = NeighbourDepthOptions::Start;
  EXPECT_EQ(parseNeighbourStart("auto"), Start::kAuto);
  EXPECT_EQ(parseNeighbourStart("true"), Start::kOn);
  EXPECT_EQ(parseNeighbourStart(""), Start::kOn);  // a bare command-line switch
  EXPECT_EQ(parseNeighbourStart("0"), Start::kOff);
  EXPECT_EQ(parseNeighbourStart("false"), Start::kOff);
  for (Start start : {Start::kOff, Start::kOn, Start::kAuto})
    EXPECT_EQ(parseNeighbourStart(neighbourStartName(start)), start);
  EXPECT_INPUT_ERROR(parseNeighbourStart("sometimes"), "start_from_neighbours", "'sometimes' is not true, false or auto");
}

TEST(NeighbourDepth, NewKeyframeStartsFromItsSourcesDepthOnTheWall) {
  OnlineMapperOptions options = wallOptions();
  options.neighbour_depth.start_from_neighbours = NeighbourDepthOptions::Start::kOn;
  options.neighbour_depth.start_iterations = 2;
  RecordingMapper recording(options);
  recording.estimateThreeKeyframes();
  const std::vector<Given>& calls = recording.calls;
  EXPECT_FALSE(calls[0].prior);  // keyframe 1: its source has no depth map yet, a random start
  for (size_t i = 1; i < calls.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_TRUE(calls[i].prior);
    EXPECT_EQ(calls[i].prior_iterations, 2);
    EXPECT_TRUE(calls[i].source_depths.empty());  // no geometric term for a first estimate
    // Every carried plane is the wall, exactly; 0.5 m apart at 5 m with f =
    // 30 px, the neighbours see all but the outer 3 columns of the 32 x 24 image.
    EXPECT_EQ(calls[i].prior_pixels_on_wall, calls[i].prior_pixels);
    EXPECT_GE(calls[i].prior_pixels, 29u * 24u);
  }
}

TEST(NeighbourDepth, GeometricRefinementUsesTheSourcesDepthMapsFromItsOwn) {
  OnlineMapperOptions options = wallOptions();
  options.neighbour_depth.geometric_refinement = true;
  options.neighbour_depth.geometric_iterations = 4;
  RecordingMapper recording(options);
  recording.estimateThreeKeyframes();
  const std::vector<Given>& calls = recording.calls;
  for (const Given& given : calls) EXPECT_TRUE(given.source_depths.empty());  // first estimates: photometric
  // Keyframe 0 is refined with {1, 2}: both have depth maps; it starts from
  // its own (the wall: every pixel).
  KeyframeResult result;
  ASSERT_TRUE(recording.mapper.refine(&result));
  EXPECT_EQ(result.id, 0);
  ASSERT_EQ(calls.size(), 4u);
  EXPECT_EQ(calls[3].source_depths, (std::vector<bool>{true, true}));
  EXPECT_TRUE(calls[3].prior);
  EXPECT_EQ(calls[3].prior_iterations, 4);
  EXPECT_EQ(calls[3].prior_pixels_on_wall, size_t(test::kKeyframeWidth * test::kKeyframeHeight));
}

TEST(NeighbourDepth, OptionsAreChecked) {
  OnlineMapperOptions options = wallOptions();
  options.neighbour_depth.start_iterations = -1;
  options.neighbour_depth.start_max_cost = std::nan("");
  options.neighbour_depth.geometric_iterations = 0;
  const std::string why = options.validate();
  for (const char* needle : {"neighbour_depth: start_iterations", "neighbour_depth: start_max_cost",
                             "neighbour_depth: geometric_iterations"}) {
    EXPECT_NE(why.find(needle), std::string::npos) << needle << " in: " << why;
  }
}

}  // namespace
}  // namespace amhmvs
