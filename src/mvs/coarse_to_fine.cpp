#include "amhmvs_mapping/mvs/coarse_to_fine.h"

#include <algorithm>
#include <cmath>
#include <vector>


namespace amhmvs {
namespace mvs {
namespace {

int scaledSide(int side, int shift) { return std::max(1, static_cast<int>(std::lround(std::ldexp(side, -shift)))); }

// The problem with every image area-downsampled by 2^shift (no source depth
// maps, no prior): keyed images from `cache` (made once, with keys of their
// own) when there is one, the others made for this estimate only.
struct ScaledProblem {
  DepthProblem problem;
  std::vector<ImageU8> owned;  // the unkeyed images' copies (moving keeps their pixels)
};

ScaledProblem downsampledProblem(const DepthProblem& problem, int shift, ScaledImageCache* cache) {
  ScaledProblem out;
  const auto scaled = [&](const PinholeCamera& camera, const ImageViewU8& image, int64_t key,
                          ImageViewU8* scaled_image, int64_t* scaled_key) {
    const PinholeCamera scaled_camera = camera.resized(scaledSide(camera.width, shift), scaledSide(camera.height, shift));
    if (cache && key != kNoImageKey) {
      const ScaledImageCache::Scaled copy = cache->get(image, key, scaled_camera.width, scaled_camera.height);
      *scaled_image = copy.image;
      *scaled_key = copy.key;
    } else {
      out.owned.push_back(resizeArea(image, scaled_camera.width, scaled_camera.height));
      *scaled_image = out.owned.back();
      *scaled_key = kNoImageKey;
    }
    return scaled_camera;
  };
  out.owned.reserve(problem.source_cameras.size() + 1);
  DepthProblem& p = out.problem;
  p.reference_camera = scaled(problem.reference_camera, problem.reference_image, problem.reference_key,
                              &p.reference_image, &p.reference_key);
  const size_t sources = problem.source_cameras.size();
  p.source_images.resize(sources);
  p.source_keys.assign(sources, kNoImageKey);
  for (size_t j = 0; j < sources; ++j) {
    const int64_t key = problem.source_keys.empty() ? kNoImageKey : problem.source_keys[j];
    p.source_cameras.push_back(
        scaled(problem.source_cameras[j], problem.source_images[j], key, &p.source_images[j], &p.source_keys[j]));
  }
  p.depth_min = problem.depth_min;
  p.depth_max = problem.depth_max;
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
                              const ScaleEstimate& estimate, ScaledImageCache* cache) {
  PatchMatchOptions single = options;
  single.multiscale_levels = 1;
  const PinholeCamera& reference = problem.reference_camera;
  const int scales =
      static_cast<int>(scaleSizes(reference.width, reference.height, options.multiscale_levels, options.window_radius).size());
  if (scales == 1 || !problem.source_depths.empty()) return estimate(single, problem);

  // Coarse problems, coarsest first; the full-scale problem is the caller's.
  std::vector<ScaledProblem> coarse;
  for (int shift = scales - 1; shift >= 1; --shift) coarse.push_back(downsampledProblem(problem, shift, cache));
  PatchMatchOptions finer = single;
  finer.num_iterations = options.multiscale_iterations;
  finer.first_iteration = options.bisection_only_iterations;

  // The problem's own start, carried to the coarsest scale.
  PlaneMap given_start;
  if (problem.prior_depth.data) {
    given_start = resamplePlanes(problem.prior_depth, problem.prior_normal, reference, problem.reference_image,
                                 coarse[0].problem.reference_camera, coarse[0].problem.reference_image);
  }
  DepthMap map;
  double milliseconds = 0, compute_milliseconds = 0;
  for (int scale = 0; scale < scales; ++scale) {
    DepthProblem scale_problem = scale + 1 == scales ? problem : coarse[scale].problem;
    if (scale > 0) {
      // The backend carries the last scale's planes to this one.
      const DepthProblem& last = coarse[scale - 1].problem;
      scale_problem.prior_depth = scale_problem.prior_normal = ImageViewF();
      scale_problem.coarser =
          DepthProblem::CoarserScale{last.reference_camera, last.reference_image, map.depth, map.normal};
    } else if (!given_start.depth.empty()) {
      scale_problem.prior_depth = given_start.depth;
      scale_problem.prior_normal = given_start.normal;
    }
    map = estimate(scale > 0 ? finer : single, scale_problem);
    milliseconds += map.milliseconds;
    compute_milliseconds += map.compute_milliseconds;
  }
  map.milliseconds = milliseconds;
  map.compute_milliseconds = compute_milliseconds;
  return map;
}

}  // namespace mvs
}  // namespace amhmvs
