// Checkerboard propagation patterns (propagation_pattern.h, paper section 3.1)
// and the per-region candidate choice of propagateCandidates()
// (patchmatch_pixel.h).
#include "amhmvs_mapping/mvs/propagation_pattern.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mvs/backends.h"
#include "amhmvs_mapping/mvs/patchmatch_pixel.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

using Offset = std::pair<int, int>;  // (dx, dy)
using OffsetSet = std::set<Offset>;

enum Region { kNearUp, kNearDown, kNearLeft, kNearRight, kFarUp, kFarDown, kFarLeft, kFarRight };

std::vector<Offset> regionOffsets(const PropagationPattern& p, int region) {
  std::vector<Offset> out;
  for (int k = p.begin[region]; k < p.begin[region + 1]; ++k) {
    out.emplace_back(p.offsets[k].dx, p.offsets[k].dy);
  }
  return out;
}

OffsetSet regionSet(const PropagationPattern& p, int region) {
  const std::vector<Offset> v = regionOffsets(p, region);
  return OffsetSet(v.begin(), v.end());
}

// The paper's upward V (our notes), written out independently of the library.
const OffsetSet kUpV = {{0, -1}, {-1, -2}, {1, -2}, {-2, -3}, {2, -3}, {-3, -4}, {3, -4}};

// Image-frame maps (x right, y down) of an upward offset onto the other directions.
Offset mirrorY(Offset o) { return {o.first, -o.second}; }
Offset rotateToLeft(Offset o) { return {o.second, -o.first}; }   // (0,-1) -> (-1,0)
Offset rotateToRight(Offset o) { return {-o.second, o.first}; }  // (0,-1) -> (1,0)

template <class F>
OffsetSet mapSet(const OffsetSet& s, F f) {
  OffsetSet out;
  for (const Offset& o : s) out.insert(f(o));
  return out;
}

// Expected regions of a scheme, in the documented order, built here from the
// paper's description rather than from the library table.
std::vector<std::vector<Offset>> expectedRegions(PropagationScheme scheme) {
  std::vector<std::vector<Offset>> regions(kNumRegions);
  if (scheme == PropagationScheme::kSymmetric) {
    regions = {{{0, -1}}, {{0, 1}}, {{-1, 0}}, {{1, 0}},
               {{0, -5}}, {{0, 5}}, {{-5, 0}}, {{5, 0}}};
    return regions;
  }
  for (const Offset& o : kUpV) {
    regions[kNearUp].push_back(o);
    regions[kNearDown].push_back(mirrorY(o));
    regions[kNearLeft].push_back(rotateToLeft(o));
    regions[kNearRight].push_back(rotateToRight(o));
  }
  for (int dist = 3; dist <= 23; dist += 2) {
    regions[kFarUp].push_back({0, -dist});
    regions[kFarDown].push_back({0, dist});
    regions[kFarLeft].push_back({-dist, 0});
    regions[kFarRight].push_back({dist, 0});
  }
  return regions;
}

std::string schemeName(const ::testing::TestParamInfo<PropagationScheme>& info) {
  return info.param == PropagationScheme::kAsymmetric ? "Asymmetric" : "Symmetric";
}

class PatternBothSchemes : public ::testing::TestWithParam<PropagationScheme> {};

TEST_P(PatternBothSchemes, EveryOffsetIsOnTheOtherColour) {
  const PropagationPattern p = makePropagationPattern(GetParam());
  ASSERT_GT(p.begin[kNumRegions], 0);
  for (int k = 0; k < p.begin[kNumRegions]; ++k) {
    const int dx = p.offsets[k].dx, dy = p.offsets[k].dy;
    // Odd dx + dy: the candidate has the other checkerboard colour, so a pass
    // never reads a pixel it writes.
    EXPECT_EQ(std::abs(dx + dy) % 2, 1) << "offset " << k << " (" << dx << "," << dy << ")";
  }
}

TEST_P(PatternBothSchemes, NoOffsetRepeatedAndRegionsPointTheirWay) {
  const PropagationPattern p = makePropagationPattern(GetParam());
  OffsetSet all;
  int total = 0;
  for (int r = 0; r < kNumRegions; ++r) {
    for (const Offset& o : regionOffsets(p, r)) {
      ++total;
      all.insert(o);
      const int dx = o.first, dy = o.second;
      // Each region lies strictly in its direction's quadrant cone.
      switch (r % 4) {
        case 0: EXPECT_TRUE(dy < 0 && std::abs(dx) < -dy) << r << ": " << dx << "," << dy; break;
        case 1: EXPECT_TRUE(dy > 0 && std::abs(dx) < dy) << r << ": " << dx << "," << dy; break;
        case 2: EXPECT_TRUE(dx < 0 && std::abs(dy) < -dx) << r << ": " << dx << "," << dy; break;
        default: EXPECT_TRUE(dx > 0 && std::abs(dy) < dx) << r << ": " << dx << "," << dy; break;
      }
    }
  }
  // Disjoint regions, no repeats: as many distinct offsets as entries.
  EXPECT_EQ(static_cast<int>(all.size()), total);
  EXPECT_EQ(total, p.begin[kNumRegions]);
}

TEST_P(PatternBothSchemes, MatchesThePaperRegionByRegion) {
  const PropagationPattern p = makePropagationPattern(GetParam());
  const std::vector<std::vector<Offset>> expected = expectedRegions(GetParam());
  for (int r = 0; r < kNumRegions; ++r) {
    EXPECT_EQ(regionSet(p, r), OffsetSet(expected[r].begin(), expected[r].end())) << "region " << r;
  }
}

INSTANTIATE_TEST_SUITE_P(Schemes, PatternBothSchemes,
                         ::testing::Values(PropagationScheme::kAsymmetric,
                                           PropagationScheme::kSymmetric),
                         schemeName);

TEST(PropagationPattern, AsymmetricRegionSizes) {
  const PropagationPattern p = makePropagationPattern(PropagationScheme::kAsymmetric);
  EXPECT_EQ(p.begin[0], 0);
  const int sizes[kNumRegions] = {7, 7, 7, 7, 11, 11, 11, 11};
  for (int r = 0; r < kNumRegions; ++r) EXPECT_EQ(p.regionSize(r), sizes[r]) << "region " << r;
  EXPECT_EQ(p.begin[kNumRegions], 72);
}

TEST(PropagationPattern, SymmetricRegionSizesAndDistances) {
  const PropagationPattern p = makePropagationPattern(PropagationScheme::kSymmetric);
  EXPECT_EQ(p.begin[0], 0);
  for (int r = 0; r < kNumRegions; ++r) EXPECT_EQ(p.regionSize(r), 1) << "region " << r;
  // Gipuma's fast neighbours: distance 1 (near) and 5 (far) along the axes, in
  // the order up, down, left, right.
  const Offset expected[kNumRegions] = {{0, -1}, {0, 1}, {-1, 0}, {1, 0},
                                        {0, -5}, {0, 5}, {-5, 0}, {5, 0}};
  for (int r = 0; r < kNumRegions; ++r) {
    EXPECT_EQ(Offset(p.offsets[p.begin[r]].dx, p.offsets[p.begin[r]].dy), expected[r]) << r;
  }
}

TEST(PropagationPattern, UpwardVIsExactlyThePapersV) {
  const PropagationPattern p = makePropagationPattern(PropagationScheme::kAsymmetric);
  const std::vector<Offset> up = regionOffsets(p, kNearUp);
  ASSERT_EQ(up.size(), 7u);
  EXPECT_EQ(OffsetSet(up.begin(), up.end()), kUpV);
}

TEST(PropagationPattern, OtherVsAreMirrorAndRotationsOfTheUpwardV) {
  const PropagationPattern p = makePropagationPattern(PropagationScheme::kAsymmetric);
  EXPECT_EQ(regionSet(p, kNearDown), mapSet(kUpV, mirrorY));
  EXPECT_EQ(regionSet(p, kNearLeft), mapSet(kUpV, rotateToLeft));
  EXPECT_EQ(regionSet(p, kNearRight), mapSet(kUpV, rotateToRight));
  // Spot values, so that a wrong map in this test cannot hide a wrong table.
  EXPECT_EQ(regionSet(p, kNearLeft).count(Offset(-1, 0)), 1u);
  EXPECT_EQ(regionSet(p, kNearLeft).count(Offset(-4, 3)), 1u);
  EXPECT_EQ(regionSet(p, kNearRight).count(Offset(4, -3)), 1u);
  EXPECT_EQ(regionSet(p, kNearDown).count(Offset(-3, 4)), 1u);
}

TEST(PropagationPattern, FarLinesAtOddDistances3To23) {
  const PropagationPattern p = makePropagationPattern(PropagationScheme::kAsymmetric);
  const Offset axis[4] = {{0, -1}, {0, 1}, {-1, 0}, {1, 0}};
  for (int dir = 0; dir < 4; ++dir) {
    OffsetSet expected;
    for (int dist = 3; dist <= 23; dist += 2) {
      expected.insert({axis[dir].first * dist, axis[dir].second * dist});
    }
    ASSERT_EQ(expected.size(), 11u);
    EXPECT_EQ(regionSet(p, kFarUp + dir), expected) << "direction " << dir;
  }
}

// --- propagateCandidates -----------------------------------------------------

// A 50x50 reference view (room for whole far lines, 23 px, around the centre)
// with fronto-parallel planes whose depth encodes the pixel index
// (depth = 1 + index / 1000, inside [1, 10]) and distinct costs.
class PropagateCandidates : public ::testing::TestWithParam<PropagationScheme> {
 protected:
  static constexpr int kSize = 50;
  static constexpr int kCentre = kSize / 2;  // all 72 candidates inside

  void SetUp() override {
    DepthProblem problem;
    PinholeCamera ref = test::centredCamera(kSize, kSize, 40);
    PinholeCamera src = ref;
    src.t = Eigen::Vector3d(-0.1, 0, 0);  // centre at x = 0.1 m
    problem.reference_camera = ref;
    const ImageU8 grey(kSize, kSize, 1, 128);
    problem.reference_image = grey;
    problem.source_cameras = {src};
    problem.source_images = {grey};
    problem.depth_min = 1;
    problem.depth_max = 10;
    ASSERT_EQ(problem.validate(), "");
    PatchMatchOptions options;
    options.propagation = GetParam();
    params_ = makePatchMatchParams(options, problem);

    const int n = kSize * kSize;
    planes_.resize(n);
    costs_.resize(n);
    selected_.assign(n, 0);
    best_view_.assign(n, -1);
    for (int i = 0; i < n; ++i) {
      planes_[i] = {{0.0f, 0.0f, -1.0f}, 1.0f + 0.001f * i};
      // 7919 is prime to 2500: a permutation, so all costs differ (no ties).
      costs_[i] = static_cast<float>((i * 7919) % n) / n;
    }
    state_ = {planes_.data(), costs_.data(), selected_.data(), best_view_.data()};
  }

  // Pixel indices whose planes propagateCandidates() returns, in order.
  std::vector<int> propagated(int x, int y) const {
    Plane hypotheses[kNumRegions];
    const Vec3 ray = pixelRay(params_.K, static_cast<float>(x), static_cast<float>(y));
    const int count = propagateCandidates(params_, state_, x, y, ray, hypotheses);
    EXPECT_GE(count, 0);
    EXPECT_LE(count, kNumRegions);
    std::vector<int> out;
    for (int i = 0; i < count; ++i) {
      out.push_back(static_cast<int>(std::lround((hypotheses[i].d - 1.0f) * 1000.0f)));
    }
    return out;
  }

  // Brute force from the paper's regions: per region, the in-image candidate
  // of lowest cost; regions with none are skipped.
  std::vector<int> expected(int x, int y, int* regions_used = nullptr) const {
    std::vector<int> out;
    for (const std::vector<Offset>& region : expectedRegions(GetParam())) {
      int best = -1;
      for (const Offset& o : region) {
        const int nx = x + o.first, ny = y + o.second;
        if (nx < 0 || ny < 0 || nx >= kSize || ny >= kSize) continue;
        const int idx = ny * kSize + nx;
        if (best < 0 || costs_[idx] < costs_[best]) best = idx;
      }
      if (best >= 0) out.push_back(best);
    }
    if (regions_used) *regions_used = static_cast<int>(out.size());
    return out;
  }

  PatchMatchParams params_;
  std::vector<Plane> planes_;
  std::vector<float> costs_;
  std::vector<uint32_t> selected_;
  std::vector<int8_t> best_view_;
  PixelState state_;
};

TEST_P(PropagateCandidates, CornerGetsOnlyDownAndRightRegions) {
  // Top-left: near down, near right, far down, far right.
  const std::vector<int> got = propagated(0, 0);
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got, expected(0, 0));
  // No hypothesis comes from the pixel itself.
  for (int idx : got) EXPECT_TRUE(idx % kSize > 0 || idx / kSize > 0) << idx;
  // Bottom-right: only up and left.
  EXPECT_EQ(propagated(kSize - 1, kSize - 1).size(), 4u);
  EXPECT_EQ(propagated(kSize - 1, kSize - 1), expected(kSize - 1, kSize - 1));
}

TEST_P(PropagateCandidates, InteriorPixelGetsEight) {
  const std::vector<int> got = propagated(15, 15);
  ASSERT_EQ(got.size(), 8u);
  EXPECT_EQ(got, expected(15, 15));
}

TEST_P(PropagateCandidates, EveryPixelMatchesBruteForce) {
  // Covers all border cases, including lines that would wrap into the next row
  // if the bounds test were done on the linear index.
  int with_eight = 0, with_four = 0;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      int used = 0;
      const std::vector<int> want = expected(x, y, &used);
      ASSERT_EQ(propagated(x, y), want) << "pixel (" << x << "," << y << ")";
      with_eight += used == 8;
      with_four += used == 4;
    }
  }
  EXPECT_EQ(with_four, 4);  // the four corners
  EXPECT_GT(with_eight, 0);
}

TEST_P(PropagateCandidates, LowestCostCandidateWinsInEveryRegion) {
  // Make each candidate of each region in turn the cheapest of the image: it
  // must be the region's hypothesis (catches an inverted comparison anywhere).
  const int x = kCentre, y = kCentre;
  const std::vector<std::vector<Offset>> regions = expectedRegions(GetParam());
  for (int r = 0; r < kNumRegions; ++r) {
    for (const Offset& o : regions[r]) {
      const int idx = (y + o.second) * kSize + (x + o.first);
      const float saved = costs_[idx];
      costs_[idx] = -1.0f;
      const std::vector<int> got = propagated(x, y);
      ASSERT_EQ(got.size(), 8u);
      EXPECT_EQ(got[r], idx) << "region " << r << " offset (" << o.first << "," << o.second << ")";
      // The other regions are unaffected.
      EXPECT_EQ(got, expected(x, y));
      costs_[idx] = saved;
    }
  }
}

TEST_P(PropagateCandidates, RegionWithNoCandidateInsideContributesNothing) {
  // At (15, 1) the far-up line starts at y = -2: nothing. The near-up V keeps
  // only (15, 0), which must win even with the highest cost in the image.
  const int near_up = 15;  // (15, 0)
  costs_[near_up] = 5.0f;
  const std::vector<int> got = propagated(15, 1);
  ASSERT_EQ(got.size(), 7u);
  EXPECT_EQ(got, expected(15, 1));
  EXPECT_EQ(got[0], near_up);
  // Right border column: near right and far right both empty.
  EXPECT_EQ(propagated(kSize - 1, 15).size(), 6u);
  // One pixel in from the right: near right has (29, y) only; the far line
  // (x + 3 = 31) is out.
  const std::vector<int> one_in = propagated(kSize - 2, 15);
  EXPECT_EQ(one_in.size(), 7u);
  EXPECT_EQ(one_in, expected(kSize - 2, 15));
}

TEST_P(PropagateCandidates, UnacceptableBestCandidateDropsTheRegion) {
  // The region's cheapest plane lies out of the depth range [1, 10]: the
  // region yields no hypothesis (it is not replaced by the second best).
  const int idx = 14 * kSize + 15;  // (15, 14): near up of (15, 15)
  costs_[idx] = -1.0f;
  planes_[idx].d = 20.0f;
  const std::vector<int> got = propagated(15, 15);
  EXPECT_EQ(got.size(), 7u);
  for (int i : got) EXPECT_NE(i, 19000);  // (20 - 1) * 1000: the rejected plane
}

INSTANTIATE_TEST_SUITE_P(Schemes, PropagateCandidates,
                         ::testing::Values(PropagationScheme::kAsymmetric,
                                           PropagationScheme::kSymmetric),
                         schemeName);

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
