#include <gtest/gtest.h>

#include "amhmvs_mapping/ros/sequence_gaps.h"

namespace amhmvs_mapping {
namespace {

TEST(SequenceGaps, CountsTheNumbersSkippedAndStartsAgainWhenTheNumberingGoesBack) {
  SequenceGaps gaps;
  EXPECT_EQ(gaps.arrive(40), 0u);  // the first one seen: nothing before it is ours
  EXPECT_EQ(gaps.arrive(41), 0u);
  EXPECT_EQ(gaps.arrive(45), 3u);  // 42, 43, 44
  EXPECT_EQ(gaps.arrive(46), 0u);
  EXPECT_EQ(gaps.lost(), 3u);
  EXPECT_EQ(gaps.arrive(0), 0u);   // a new publisher
  EXPECT_EQ(gaps.arrive(2), 1u);
  EXPECT_EQ(gaps.arrive(2), 0u);   // a repeat is not a loss
  EXPECT_EQ(gaps.lost(), 4u);
  EXPECT_EQ(gaps.arrive(0xffffffffu), 0xffffffffull - 3);  // the widest jump does not overflow
}

}  // namespace
}  // namespace amhmvs_mapping
