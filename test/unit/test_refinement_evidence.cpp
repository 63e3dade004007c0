// judgeRefinement (refinement_evidence.h): a refined depth map replaces the
// old one only when the estimator's own evidence (median cost on the pixels
// valid in both, confident pixels) says it is not worse.
#include "amhmvs_mapping/mapping/refinement_evidence.h"

#include <gtest/gtest.h>

#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A 20x10 depth map at 2 m with one cost everywhere; the first `invalid`
// pixels have no depth.
DepthMap uniformMap(float cost, int invalid = 0) {
  DepthMap map;
  map.depth = ImageF(20, 10, 1, 2.0f);
  map.cost = ImageF(20, 10, 1, cost);
  for (int i = 0; i < invalid; ++i) map.depth.data[i] = kNaN;
  return map;
}

TEST(RefinementEvidence, WorseCostsAreRejectedAndBetterOnesKept) {
  const RefinementVerdict worse = judgeRefinement(uniformMap(0.3f), uniformMap(0.8f), 0.5);
  EXPECT_FALSE(worse.keep_new);
  EXPECT_EQ(worse.old_map.confident_pixels, 200u);
  EXPECT_EQ(worse.new_map.confident_pixels, 0u);
  EXPECT_NEAR(worse.new_map.median_cost, 0.8, 1e-6);
  EXPECT_EQ(worse.common_pixels, 200u);
  EXPECT_NE(worse.reason.find("median cost 0.3 -> 0.8"), std::string::npos) << worse.reason;

  const RefinementVerdict better = judgeRefinement(uniformMap(0.3f), uniformMap(0.2f), 0.5);
  EXPECT_TRUE(better.keep_new) << better.reason;
  EXPECT_TRUE(judgeRefinement(uniformMap(0.3f), uniformMap(0.3f), 0.5).keep_new);  // equal: not worse
}

TEST(RefinementEvidence, FewerConfidentPixelsAreRejectedEvenAtALowerMedianCost) {
  // The new map scores its remaining pixels lower but loses half of them.
  const RefinementVerdict verdict = judgeRefinement(uniformMap(0.3f), uniformMap(0.2f, 100), 0.5);
  EXPECT_FALSE(verdict.keep_new) << verdict.reason;
  EXPECT_EQ(verdict.common_pixels, 100u);
  EXPECT_EQ(verdict.new_map.confident_pixels, 100u);
}

TEST(RefinementEvidence, NothingToCompareKeepsTheNewMap) {
  DepthMap no_cost = uniformMap(0.3f);
  no_cost.cost = ImageF();
  EXPECT_TRUE(judgeRefinement(no_cost, uniformMap(0.9f), 0.5).keep_new);
  EXPECT_TRUE(judgeRefinement(uniformMap(0.3f, 200), uniformMap(0.9f), 0.5).keep_new);  // old: no valid pixel
  DepthMap small = uniformMap(0.3f);
  small.depth = ImageF(10, 10, 1, 2.0f);
  EXPECT_THROW(judgeRefinement(uniformMap(0.3f), small, 0.5), InputError);
}

}  // namespace
}  // namespace amhmvs
