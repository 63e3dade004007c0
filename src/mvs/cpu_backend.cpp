// CPU backend: the per-pixel algorithm of patchmatch_pixel.h in OpenMP loops.
#include <chrono>
#include <memory>

#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "amhmvs_mapping/mvs/plane_map.h"
#include "backends.h"

namespace amhmvs {
namespace mvs {
namespace {

// Initialisation and all iterations; the state is left in `state`.
template <class Window>
void runPatchMatch(const PatchMatchParams& P, const CpuSampler& sampler, PixelState state,
                   int iterations) {
  const int width = P.width, height = P.height;
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) initializePixel<Window>(P, sampler, state, x, y);
  }
  for (int iteration = 0; iteration < iterations; ++iteration) {
    for (int colour = 0; colour < 2; ++colour) {
#pragma omp parallel for schedule(dynamic, 4)
      for (int y = 0; y < height; ++y) {
        for (int x = (y + colour) & 1; x < width; x += 2) {
          updatePixel<Window>(P, P.sources, sampler, state, P.first_iteration + iteration, x, y);
        }
      }
    }
  }
}

}  // namespace

DepthMap estimateOnCpu(const PatchMatchOptions& options, const PatchMatchParams& params,
                       const DepthProblem& problem) {
  const auto start = std::chrono::steady_clock::now();
  PatchMatchParams P = params;
  const std::vector<float> source_depths = concatenateSourceDepths(problem, &P);
  P.source_depths = source_depths.data();
  if (problem.prior_depth.data) {
    P.prior_depth = problem.prior_depth.data;
    P.prior_normal = problem.prior_normal.data;
  }
  if (problem.planar_prior_depth.data) {
    P.planar.depth = problem.planar_prior_depth.data;
    P.planar.normal = problem.planar_prior_normal.data;
  }
  PlaneMap carried;  // a coarser scale's planes at this scale
  if (problem.coarser) {
    const DepthProblem::CoarserScale& c = *problem.coarser;
    carried = resamplePlanes(c.depth, c.normal, c.camera, c.image, problem.reference_camera, problem.reference_image);
    P.prior_depth = carried.depth.data.data();
    P.prior_normal = carried.normal.data.data();
  }
  CpuSampler sampler{};
  sampler.reference_image = problem.reference_image;
  std::vector<std::unique_ptr<PaddedImage8>> padded;
  for (int j = 0; j < P.num_sources; ++j) {
    padded.push_back(std::make_unique<PaddedImage8>(problem.source_images[j]));
    sampler.sources[j] = padded.back().get();
  }

  const int width = P.width, height = P.height;
  const size_t pixels = static_cast<size_t>(width) * height;
  std::vector<Plane> planes(pixels);
  std::vector<float> costs(pixels);
  std::vector<uint32_t> selected(pixels);
  std::vector<int8_t> best_view(pixels);
  const PixelState state{planes.data(), costs.data(), selected.data(), best_view.data()};
  withWindowType(P, [&](auto window) {
    runPatchMatch<typename decltype(window)::type>(P, sampler, state, options.num_iterations);
  });

  DepthMap out;
  out.backend = Backend::kCpu;
  ImageF raw(width, height);
  out.normal = ImageF(width, height, 3);
  out.cost = ImageF(width, height);
#pragma omp parallel for
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      Vec3 n;
      pixelOutput(P, state, x, y, &raw.at(x, y), &n, &out.cost.at(x, y));
      out.normal.at(x, y, 0) = n.x;
      out.normal.at(x, y, 1) = n.y;
      out.normal.at(x, y, 2) = n.z;
    }
  }
  out.depth = ImageF(width, height);
#pragma omp parallel for
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      out.depth.at(x, y) = medianDepth(raw.data.data(), width, height, x, y, options.median_filter_size);
    }
  }
  out.milliseconds =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  out.compute_milliseconds = out.milliseconds;
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
