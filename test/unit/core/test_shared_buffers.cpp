// Shared<T> (core/shared.h): one immutable value for every holder, never
// null; reserveTouched (core/fresh_memory.h): a vector's new capacity is
// touched without changing its elements; PreparedVector
// (core/prepared_vector.h): vectors of the asked size, default-constructed,
// whether the one prepared ahead fits or not.
#include <gtest/gtest.h>

#include <vector>

#include "amhmvs_mapping/core/fresh_memory.h"
#include "amhmvs_mapping/core/prepared_vector.h"
#include "amhmvs_mapping/core/shared.h"
#include "amhmvs_mapping/mapping/keyframe_point.h"

namespace amhmvs {
namespace {

TEST(Shared, HoldersShareOneValueAndADefaultIsEmptyNotNull) {
  const Shared<std::vector<int>> none;
  EXPECT_TRUE(none->empty());
  EXPECT_TRUE(none.sameValue(Shared<std::vector<int>>()));  // one empty value for all defaults

  std::vector<int> values = {1, 2, 3};
  const int* buffer = values.data();
  const Shared<std::vector<int>> moved(std::move(values));
  EXPECT_EQ(moved->data(), buffer);  // taken over, not copied
  const Shared<std::vector<int>> copy = moved;
  EXPECT_TRUE(copy.sameValue(moved));
  EXPECT_EQ(&*copy, &*moved);
  const std::vector<int>& borrowed = copy;
  EXPECT_EQ(borrowed.data(), buffer);
  EXPECT_FALSE(copy.sameValue(none));
  EXPECT_EQ(*copy, (std::vector<int>{1, 2, 3}));
}

TEST(FreshMemory, ReserveTouchedKeepsTheElementsAndGrowsTheCapacity) {
  std::vector<KeyframePoint> points(5);
  for (size_t i = 0; i < points.size(); ++i) points[i].confidence = 0.5f * i;
  const size_t capacity = (size_t{4} << 20) / sizeof(KeyframePoint);  // 4 MB: touched from all cores
  reserveTouched(&points, capacity);
  ASSERT_GE(points.capacity(), capacity);
  ASSERT_EQ(points.size(), 5u);
  for (size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i].confidence, 0.5f * i);
  points.resize(capacity);  // constructed in the touched memory as usual
  EXPECT_EQ(points.back().confidence, 1.0f);
  const KeyframePoint* data = points.data();
  reserveTouched(&points, 10);  // never shrinks or moves
  EXPECT_EQ(points.data(), data);
  std::vector<uint64_t> small;
  reserveTouched(&small, 3);  // below the size worth touching in parallel
  EXPECT_GE(small.capacity(), 3u);
  EXPECT_TRUE(small.empty());
}

TEST(PreparedVector, GivesDefaultConstructedVectorsOfTheAskedSize) {
  PreparedVector<KeyframePoint> prepared;
  std::vector<KeyframePoint> first = prepared.take(1000, 50000);  // nothing prepared yet: made now
  ASSERT_EQ(first.size(), 1000u);
  std::vector<KeyframePoint> second = prepared.take(40000, 10);  // the prepared 50000, shrunk
  ASSERT_EQ(second.size(), 40000u);
  EXPECT_GE(second.capacity(), 50000u);
  EXPECT_EQ(second.back().confidence, 1.0f);  // default-constructed
  EXPECT_EQ(second.front().position, Eigen::Vector3f::Zero());
  const std::vector<KeyframePoint> third = prepared.take(20000, 10);  // prepared 10: too small, made now
  ASSERT_EQ(third.size(), 20000u);
  EXPECT_EQ(third[12345].consistent_views, 0);
  EXPECT_TRUE(prepared.take(0, 0).empty());
}

}  // namespace
}  // namespace amhmvs
