// The CPU backend scores matching costs in SIMD lanes (cpu_lanes.h,
// CpuSampler::laneCosts). Each lane must give the scalar code's result bit for
// bit: the texture fetch, the matching cost, and whole PatchMatch runs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "mvs/backends.h"
#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "synthetic_problem.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

// Coordinates that exercise every branch of the fetch: inside, the padded
// border, far outside, non-finite, and fractions on the rounding ties of the
// 1/256 grid and of the weights.
std::vector<float> testCoordinates(int size, std::mt19937* rng) {
  std::vector<float> c = {0.0f, -0.5f, -2.0f, -2.5f, -1e9f, 1e9f,
                          static_cast<float>(size) - 0.5f, static_cast<float>(size) + 2.0f,
                          std::numeric_limits<float>::quiet_NaN(),
                          std::numeric_limits<float>::infinity(),
                          -std::numeric_limits<float>::infinity()};
  std::uniform_real_distribution<float> anywhere(-6.0f, size + 6.0f);
  std::uniform_int_distribution<int> grid(-3 * 512, (size + 3) * 512);
  for (int i = 0; i < 3000; ++i) c.push_back(anywhere(*rng));
  for (int i = 0; i < 3000; ++i) c.push_back(grid(*rng) / 512.0f);  // half steps of 1/256
  return c;
}

TEST(CpuLanes, SampleEqualsScalarTextureFetchInEveryLane) {
  // Two images of different sizes, alternating over the lanes.
  const ImageU8 small = test::randomImage(37, 23, 1, 3), large = test::randomImage(61, 40, 1, 4);
  const PaddedImage8 padded_small(small), padded_large(large);
  const PaddedImage8* images[kCpuLanes];
  for (int l = 0; l < kCpuLanes; ++l) images[l] = l % 2 ? &padded_large : &padded_small;
  std::mt19937 rng(11);
  const std::vector<float> xs = testCoordinates(61, &rng), ys = testCoordinates(40, &rng);
  std::uniform_int_distribution<size_t> pick(0, xs.size() - 1);

  for (bool short_offsets : {true, false}) {
    CpuSourceLanes lanes;
    CpuSourceView scalar[kCpuLanes];
    for (int l = 0; l < kCpuLanes; ++l) {
      const PaddedImage8& image = *images[l];
      // A row limit beyond 16 bits takes the general gather path.
      const int max_row = short_offsets ? image.height + kPadding : 40000;
      lanes.texels.setLane(l, image.origin, image.stride, max_row);
      scalar[l] = {image.origin, image.stride, image.width + kCoordinateMargin,
                   image.height + kCoordinateMargin};
      lanes.max_x[l] = scalar[l].max_x;
      lanes.max_y[l] = scalar[l].max_y;
    }
    lanes.texels.finish();
    int compared = 0, mismatches = 0;
    for (int trial = 0; trial < 20000; ++trial) {
      FloatLanes x, y;
      for (int l = 0; l < kCpuLanes; ++l) {
        x[l] = xs[pick(rng)];
        y[l] = ys[pick(rng)];
      }
      const FloatLanes got = lanes.sample(x, y);
      for (int l = 0; l < kCpuLanes; ++l, ++compared) {
        const float want = scalar[l].sample(x[l], y[l]);
        if (!sameBits(got[l], want)) {
          if (++mismatches <= 5) {
            ADD_FAILURE() << "lane " << l << " at (" << x[l] << ", " << y[l] << "): " << got[l]
                          << " vs scalar " << want;
          }
        }
      }
    }
    EXPECT_EQ(mismatches, 0) << "short offsets " << short_offsets;
    EXPECT_EQ(compared, 20000 * kCpuLanes);
  }
}

// A synthetic problem with its CPU sampler.
struct SampledProblem {
  SyntheticProblem problem;
  PatchMatchParams params;
  std::vector<std::unique_ptr<PaddedImage8>> padded;
  CpuSampler sampler{};

  SampledProblem(int width, int height, int sources)
      : problem(makeSyntheticProblem(width, height, sources, 5)) {
    params = makePatchMatchParams(PatchMatchOptions(), problem.problem);
    sampler.reference_image = problem.problem.reference_image;
    for (int j = 0; j < params.num_sources; ++j) {
      padded.push_back(std::make_unique<PaddedImage8>(problem.problem.source_images[j]));
      sampler.sources[j] = padded.back().get();
    }
  }
};

// 6 sources: batches of 4 lanes end part-filled; some planes face away or
// map the window outside a source, some windows are flat.
template <class Window>
void expectBatchedCostsEqualScalar(const SampledProblem& s) {
  const PatchMatchParams& P = s.params;
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> px(0, P.width - 1), py(0, P.height - 1), count(1, 19);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), depth(0.3f, 12.0f);
  int compared = 0, max_cost = 0, mismatches = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int x = px(rng), y = py(rng);
    ReferenceWindow win;
    computeReferenceWindow<Window>(s.sampler, P.cost, x, y, &win);
    const int n = count(rng);
    std::vector<Vec3> q(n);
    std::vector<int> view(n);
    std::vector<float> got(n, -1.0f);
    CostBatch<Window, CpuSampler, InlineSamples> batch(s.sampler, P.cost, win, x, y);
    for (int k = 0; k < n; ++k) {
      const Vec3 normal = normalized(make_vec3(unit(rng), unit(rng), -1.5f + unit(rng)));
      const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
      q[k] = planeTerm(P.K, planeFromDepthNormal(normal, depth(rng), ray));
      view[k] = k % P.num_sources;
      batch.add(P.sources[view[k]], q[k], &got[k]);
    }
    batch.flush();
    for (int k = 0; k < n; ++k, ++compared) {
      const float want = matchingCost<Window>(s.sampler, P.cost, win, P.sources[view[k]],
                                                   q[k], x, y);
      max_cost += want == kMaxCost;
      if (!sameBits(got[k], want) && ++mismatches <= 5) {
        ADD_FAILURE() << "pixel (" << x << ", " << y << ") view " << view[k] << ": " << got[k]
                      << " vs scalar " << want;
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(compared, 2000);
  EXPECT_GT(max_cost, 20);               // the kMaxCost branches were taken
  EXPECT_LT(max_cost, compared * 3 / 4);  // and most costs were real scores
}

TEST(CpuLanes, BatchedCostsEqualScalarMatchingCosts) {
  expectBatchedCostsEqualScalar<PaperWindow>(SampledProblem(96, 72, 6));
}

// The CPU sampler scoring one cost at a time, as the scalar code did.
struct ScalarCpuSampler : CpuSampler {
  static constexpr int kLanes = 1;
};

template <class Sampler>
std::vector<float> runPatchMatchState(const PatchMatchParams& P, const Sampler& sampler,
                                      int iterations) {
  const size_t pixels = static_cast<size_t>(P.width) * P.height;
  std::vector<Plane> planes(pixels);
  std::vector<float> costs(pixels);
  std::vector<uint32_t> selected(pixels);
  std::vector<int8_t> best_view(pixels);
  const PixelState state{planes.data(), costs.data(), selected.data(), best_view.data()};
  for (int y = 0; y < P.height; ++y) {
    for (int x = 0; x < P.width; ++x) initializePixel<PaperWindow>(P, sampler, state, x, y);
  }
  for (int iteration = 0; iteration < iterations; ++iteration) {
    for (int colour = 0; colour < 2; ++colour) {
      for (int y = 0; y < P.height; ++y) {
        for (int x = (y + colour) & 1; x < P.width; x += 2) {
          updatePixel<PaperWindow>(P, P.sources, sampler, state, iteration, x, y);
        }
      }
    }
  }
  std::vector<float> flat;  // planes then costs
  for (const Plane& p : planes) flat.insert(flat.end(), {p.n.x, p.n.y, p.n.z, p.d});
  flat.insert(flat.end(), costs.begin(), costs.end());
  for (uint32_t v : selected) flat.push_back(static_cast<float>(v));
  return flat;
}

TEST(CpuLanes, PatchMatchStateEqualsScalarEvaluation) {
  // 6 iterations: bisection-only and COLMAP-style refinement (whose five
  // candidates the lanes score together) both run.
  for (int sources : {3, 4}) {
    SampledProblem s(64, 48, sources);
    ScalarCpuSampler scalar;
    static_cast<CpuSampler&>(scalar) = s.sampler;
    const std::vector<float> lanes = runPatchMatchState(s.params, s.sampler, 6);
    const std::vector<float> one_by_one = runPatchMatchState(s.params, scalar, 6);
    ASSERT_EQ(lanes.size(), one_by_one.size());
    EXPECT_EQ(std::memcmp(lanes.data(), one_by_one.data(), lanes.size() * sizeof(float)), 0)
        << sources << " sources";
    int scored = 0;  // the run did real work: most pixels have a finite cost
    for (int i = 0; i < s.params.width * s.params.height; ++i) {
      scored += lanes[4 * s.params.width * s.params.height + i] < 1.0f;
    }
    EXPECT_GT(scored, s.params.width * s.params.height / 2);
  }
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
