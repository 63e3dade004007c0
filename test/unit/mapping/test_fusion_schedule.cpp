#include "amhmvs_mapping/mapping/fusion_schedule.h"

#include <gtest/gtest.h>

namespace amhmvs {
namespace {

TEST(FusionSchedule, WaitsInArrivalOrderOnceEachAndLeavesWhenFused) {
  FusionSchedule schedule;
  schedule.wait(5);
  schedule.wait(2);
  schedule.wait(5);  // refined while waiting: still one entry
  EXPECT_EQ(schedule.waiting(), (std::vector<int64_t>{5, 2}));
  EXPECT_FALSE(schedule.fuse(5, {2}, false));  // the first fusion
  EXPECT_EQ(schedule.waiting(), (std::vector<int64_t>{2}));
  schedule.wait(5);
  EXPECT_TRUE(schedule.fuse(5, {2}, false));  // again: its points are replaced
  EXPECT_TRUE(schedule.forget(2));
  EXPECT_FALSE(schedule.forget(5));  // fused, not waiting
  EXPECT_TRUE(schedule.waiting().empty());
}

TEST(FusionSchedule, UnderfusedKeyframesAreCheckedAgainForEightDepthMapsThenNever) {
  FusionSchedule schedule;
  schedule.wait(1);
  schedule.fuse(1, {2, 3}, /*too_few=*/true);
  EXPECT_EQ(schedule.underfusedViews(1), 2u);
  for (int round = 0; round < FusionSchedule::kRechecks - 1; ++round) {
    schedule.depthMapChecked();
    ASSERT_EQ(schedule.underfusedToCheck(), (std::vector<int64_t>{1})) << round;
    schedule.markChecked(1);
    EXPECT_TRUE(schedule.underfusedToCheck().empty()) << "nothing changed since the check";
  }
  schedule.posesChanged();
  EXPECT_EQ(schedule.underfusedToCheck(), (std::vector<int64_t>{1}));
  schedule.depthMapChecked();  // the last recheck is used up
  EXPECT_TRUE(schedule.underfusedToCheck().empty());
  EXPECT_EQ(schedule.underfusedViews(1), 0u);
}

TEST(FusionSchedule, AWaitingKeyframeIsNotUnderfusedWork) {
  FusionSchedule schedule;
  schedule.fuse(1, {2}, true);
  schedule.wait(1);  // refined: waits for its fusion anew
  EXPECT_TRUE(schedule.underfusedToCheck().empty());
  schedule.fuse(1, {2, 3, 4}, false);
  schedule.depthMapChecked();
  EXPECT_TRUE(schedule.underfusedToCheck().empty());
}

TEST(FusionSchedule, KeyframesFusedAgainstAReplacedDepthMapComeBackOnceLowestFirst) {
  FusionSchedule schedule;
  schedule.fuse(4, {1, 2}, false);
  schedule.fuse(3, {2}, false);
  schedule.fuse(5, {1}, false);
  schedule.wait(3);
  schedule.depthMapReplaced(2);
  EXPECT_EQ(schedule.takeFusedAgainstReplaced(), std::optional<int64_t>(4));  // 3 waits: fused anyway
  EXPECT_EQ(schedule.takeFusedAgainstReplaced(), std::nullopt);
  schedule.depthMapReplaced(2);
  schedule.fuse(4, {1}, false);  // fused meanwhile: no longer against the old map
  EXPECT_EQ(schedule.takeFusedAgainstReplaced(), std::nullopt);
}

}  // namespace
}  // namespace amhmvs
