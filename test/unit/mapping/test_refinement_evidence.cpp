// judgeRefinement (refinement_evidence.h): a refined depth map replaces the
// old one only when the estimator's own evidence, its confident pixels, says
// it is not worse.
#include "amhmvs_mapping/mapping/refinement_evidence.h"

#include <gtest/gtest.h>

#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kConfidentCost = 0.5, kMaxLoss = 0.02;

// A 20x10 depth map at 2 m with one cost everywhere; the first `invalid`
// pixels have no depth.
DepthMap uniformMap(float cost, int invalid = 0) {
  DepthMap map;
  map.depth = ImageF(20, 10, 1, 2.0f);
  map.cost = ImageF(20, 10, 1, cost);
  for (int i = 0; i < invalid; ++i) map.depth.data[i] = kNaN;
  return map;
}

RefinementVerdict judge(const DepthMap& old_map, const DepthMap& new_map) {
  return judgeRefinement(old_map, new_map, kConfidentCost, kMaxLoss);
}

TEST(RefinementEvidence, MapThatLosesItsConfidentPixelsIsRejected) {
  // Bad sources: every pixel's cost rises above the confident level.
  const RefinementVerdict worse = judge(uniformMap(0.3f), uniformMap(0.8f));
  EXPECT_FALSE(worse.keep_new);
  EXPECT_EQ(worse.old_map.confident_pixels, 200u);
  EXPECT_EQ(worse.new_map.confident_pixels, 0u);
  EXPECT_NEAR(worse.new_map.median_cost, 0.8, 1e-6);
  EXPECT_EQ(worse.common_pixels, 200u);
  EXPECT_NE(worse.reason.find("confident pixels 200 -> 0, median cost 0.3 -> 0.8 on 200 common pixels"),
            std::string::npos) << worse.reason;
  // Fewer valid pixels at a lower cost: 5 of 200 confident ones lost (2.5 %).
  const RefinementVerdict fewer = judge(uniformMap(0.3f), uniformMap(0.2f, 5));
  EXPECT_FALSE(fewer.keep_new) << fewer.reason;
  EXPECT_EQ(fewer.common_pixels, 195u);
}

TEST(RefinementEvidence, MapWithAsManyConfidentPixelsIsKeptEvenAtAHigherMedianCost) {
  EXPECT_TRUE(judge(uniformMap(0.3f), uniformMap(0.2f)).keep_new);
  // More sources average more views: a higher cost, still confident.
  const RefinementVerdict more_sources = judge(uniformMap(0.1f, 20), uniformMap(0.15f));
  EXPECT_TRUE(more_sources.keep_new) << more_sources.reason;
  EXPECT_EQ(more_sources.new_map.confident_pixels, 200u);
  // Within the tolerance: 4 of 200 lost (2 %).
  EXPECT_TRUE(judge(uniformMap(0.3f), uniformMap(0.3f, 4)).keep_new);
}

TEST(RefinementEvidence, NothingToCompareKeepsTheNewMap) {
  DepthMap no_cost = uniformMap(0.3f);
  no_cost.cost = ImageF();
  EXPECT_TRUE(judge(no_cost, uniformMap(0.9f)).keep_new);
  EXPECT_TRUE(judge(uniformMap(0.3f, 200), uniformMap(0.9f)).keep_new);  // old: no valid pixel
  DepthMap small = uniformMap(0.3f);
  small.depth = ImageF(10, 10, 1, 2.0f);
  EXPECT_THROW(judge(uniformMap(0.3f), small), InputError);
}

}  // namespace
}  // namespace amhmvs
