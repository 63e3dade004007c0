#include "amhmvs_mapping/mvs/coarse_to_fine.h"

#include <algorithm>
#include <cmath>
#include <vector>


namespace amhmvs {
namespace mvs {
namespace {

int scaledSide(int side, int shift) { return std::max(1, static_cast<int>(std::lround(std::ldexp(side, -shift)))); }

// The problem with every image area-downsampled by 2^shift (no keys: these
// images exist for this estimate only; no source depth maps, no prior).
OwnedDepthProblem downsampledProblem(const DepthProblem& problem, int shift) {
  OwnedDepthProblem out;
  auto scaled = [shift](const PinholeCamera& camera) {
    return camera.resized(scaledSide(camera.width, shift), scaledSide(camera.height, shift));
  };
  const PinholeCamera reference = scaled(problem.reference_camera);
  out.setReference(reference, resizeArea(problem.reference_image, reference.width, reference.height));
  for (size_t j = 0; j < problem.source_cameras.size(); ++j) {
    const PinholeCamera source = scaled(problem.source_cameras[j]);
    out.addSource(source, resizeArea(problem.source_images[j], source.width, source.height));
  }
  out.problem.depth_min = problem.depth_min;
  out.problem.depth_max = problem.depth_max;
  return out;
}


}  // namespace

std::vector<ScaleSize> scaleSizes(int width, int height, int levels, int window_radius) {
  std::vector<ScaleSize> sizes;
  for (int shift = std::max(levels, 1) - 1; shift >= 0; --shift) {
    const ScaleSize size{scaledSide(width, shift), scaledSide(height, shift)};
    if (shift == 0 || std::min(size.width, size.height) >= kMinScaleSide * window_radius) sizes.push_back(size);
  }
  return sizes;
}

DepthMap estimateCoarseToFine(const PatchMatchOptions& options, const DepthProblem& problem,
                              const ScaleEstimate& estimate) {
  PatchMatchOptions single = options;
  single.multiscale_levels = 1;
  const PinholeCamera& reference = problem.reference_camera;
  const int scales =
      static_cast<int>(scaleSizes(reference.width, reference.height, options.multiscale_levels, options.window_radius).size());
  if (scales == 1 || !problem.source_depths.empty()) return estimate(single, problem);

  // Coarse problems, coarsest first; the full-scale problem is the caller's.
  std::vector<OwnedDepthProblem> coarse;
  for (int shift = scales - 1; shift >= 1; --shift) coarse.push_back(downsampledProblem(problem, shift));
  PatchMatchOptions finer = single;
  finer.num_iterations = options.multiscale_iterations;
  finer.first_iteration = options.bisection_only_iterations;

  DepthMap map;
  PlaneMap prior;
  const bool given_start = problem.prior_depth.data != nullptr;
  if (given_start) {
    prior = resamplePlanes(problem.prior_depth, problem.prior_normal, reference, problem.reference_image,
                           coarse[0].problem.reference_camera, coarse[0].problem.reference_image);
  }
  double milliseconds = 0, compute_milliseconds = 0;
  for (int scale = 0; scale < scales; ++scale) {
    const bool full = scale + 1 == scales;
    DepthProblem scale_problem = full ? problem : coarse[scale].problem;
    if (scale > 0 || given_start) {
      scale_problem.prior_depth = prior.depth;
      scale_problem.prior_normal = prior.normal;
    }
    map = estimate(scale > 0 ? finer : single, scale_problem);
    milliseconds += map.milliseconds;
    compute_milliseconds += map.compute_milliseconds;
    if (full) break;
    const DepthProblem& next = scale + 2 == scales ? problem : coarse[scale + 1].problem;
    prior = resamplePlanes(map.depth, map.normal, scale_problem.reference_camera, scale_problem.reference_image,
                           next.reference_camera, next.reference_image);
  }
  map.milliseconds = milliseconds;
  map.compute_milliseconds = compute_milliseconds;
  return map;
}

}  // namespace mvs
}  // namespace amhmvs
