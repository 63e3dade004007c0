// CPU backend: the per-pixel algorithm of patchmatch_pixel.h in OpenMP loops.
#include <chrono>

#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "backends.h"

namespace amhmvs {
namespace mvs {
namespace {

HostImage8 hostImage(const ImageU8& image) { return {image.data.data(), image.width, image.height}; }

}  // namespace

DepthMap estimateOnCpu(const PatchMatchOptions& options, const PatchMatchParams& P,
                       const DepthProblem& problem) {
  const auto start = std::chrono::steady_clock::now();
  CpuSampler sampler{};
  sampler.reference_image = hostImage(problem.reference_image);
  for (int j = 0; j < P.num_sources; ++j) sampler.sources[j] = hostImage(problem.source_images[j]);

  const int width = P.width, height = P.height;
  const size_t pixels = static_cast<size_t>(width) * height;
  std::vector<Plane> planes(pixels);
  std::vector<float> costs(pixels);
  std::vector<uint32_t> selected(pixels);
  std::vector<int8_t> best_view(pixels);
  const PixelState state{planes.data(), costs.data(), selected.data(), best_view.data()};

#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) initializePixel(P, sampler, state, x, y);
  }
  for (int iteration = 0; iteration < options.num_iterations; ++iteration) {
    for (int colour = 0; colour < 2; ++colour) {
#pragma omp parallel for schedule(dynamic, 4)
      for (int y = 0; y < height; ++y) {
        for (int x = (y + colour) & 1; x < width; x += 2) {
          updatePixel(P, sampler, state, iteration, x, y);
        }
      }
    }
  }

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
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
