// Multi-scale coarse-to-fine estimation (not in the paper; as ACMM, Xu & Tao
// 2019): a low-texture aid. A window of the same size covers 2^k times the
// scene at scale k, so weakly textured surfaces that give one scale's window
// nothing to match are found at a coarser one, and each finer scale starts
// from them and refines:
//
//   1. the problem at the coarsest scale (every image area-downsampled by
//      2^(levels-1), cameras scaled about pixel centres): the full schedule
//      from random planes, or from the problem's own prior carried to that
//      scale (with its schedule, DepthProblem::prior_iterations);
//   2. its planes carried to the next finer scale (resamplePlanes), the
//      prior start of that scale's estimate, which runs
//      options.multiscale_iterations iterations numbered from
//      bisection_only_iterations (local refinement, as a geometric pass);
//   3. repeated up to the full scale, whose result is returned.
//
// A driver above the backends: both run it unchanged. A problem with source
// depth maps (a geometric pass, refining a map of its own scale) runs at a
// single scale.
#pragma once

#include <functional>
#include <vector>

#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/plane_map.h"
#include "amhmvs_mapping/mvs/scaled_image_cache.h"

namespace amhmvs {
namespace mvs {

// Image sizes of the scales of a (width x height) view, coarsest first, the
// full size last: at most `levels`, each half the next (rounded), and only
// those whose shorter side is at least kMinScaleSide window radii (a scale
// too small for the matching window is left out).
struct ScaleSize {
  int width, height;
};
constexpr int kMinScaleSide = 8;  // in window radii: 40 px for the paper's 11x11 window
std::vector<ScaleSize> scaleSizes(int width, int height, int levels, int window_radius);

// One single-scale estimate with the given options (the backend's).
using ScaleEstimate = std::function<DepthMap(const PatchMatchOptions&, const DepthProblem&)>;

// Steps 1-3 above with options.multiscale_levels scales (fewer when the
// images are small; a single scale runs `estimate` once). The result's times
// are the sums over the scales. With a cache, the coarser copies of keyed
// images are made once and keep keys of their own (the cache's).
DepthMap estimateCoarseToFine(const PatchMatchOptions& options, const DepthProblem& problem,
                              const ScaleEstimate& estimate, ScaledImageCache* cache = nullptr);

}  // namespace mvs
}  // namespace amhmvs
