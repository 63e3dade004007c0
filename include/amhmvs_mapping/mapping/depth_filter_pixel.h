// Per-pixel temporal depth filter (not in the paper): each frame after a
// keyframe measures the depth of the keyframe's pixels again along the
// epipolar line, and a parametric belief combines the measurements, as
// REMODE (Pizzoli et al. 2014) does with the model of Vogiatzis and
// Hernandez (2011): a measurement x is, with inlier ratio pi, Gaussian
// around the true depth Z with the measurement's own variance tau^2, else
// uniform over [0, depth_range]; the posterior over (Z, pi) is approximated
// by N(Z | mu, sigma^2) Beta(pi | a, b), matched in its first and second
// moments after each measurement.
//
// Written once for both backends (AMHMVS_HD): the CPU loop in depth_filter.cpp
// and a CUDA kernel run the same functions. The matching cost is the
// estimator's own (matching_cost.h: eq. 15 over the plane-induced homography
// of the pixel's depth and normal).
#pragma once

#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

namespace amhmvs {
namespace filter {

using mvs::Intrinsics;
using mvs::Plane;
using mvs::SourceGeometry;
using mvs::Vec3;

// One pixel's belief: depth ~ N(mu, sigma2), inlier ratio ~ Beta(a, b).
struct DepthBelief {
  float mu;
  float sigma2;
  float a, b;
};

AMHMVS_HD float inlierProbability(const DepthBelief& belief) { return belief.a / (belief.a + belief.b); }

// The standard deviation of a depth measured in a frame whose centre is
// `centre` (reference camera frame), for a point at depth `depth` on `ray`
// (z = 1), when the match is off by `pixel_angle` radians: the triangle of
// the two centres and the point, with the frame's angle widened by it
// (REMODE's tau). Large at short baselines, where a pixel moves the depth far.
AMHMVS_HD float measurementSigma(Vec3 ray, float depth, Vec3 centre, float pixel_angle) {
  const float baseline = sqrtf(mvs::dot(centre, centre));
  if (!(baseline > 0.0f)) return INFINITY;
  const Vec3 point = depth * ray;
  const Vec3 from_frame = point - centre;
  const float point_distance = sqrtf(mvs::dot(point, point));
  const float frame_distance = sqrtf(mvs::dot(from_frame, from_frame));
  // alpha: at the reference centre between ray and baseline; beta: at the
  // frame's centre between the baseline back and the point.
  const float alpha = acosf(fminf(1.0f, fmaxf(-1.0f, mvs::dot(point, centre) / (point_distance * baseline))));
  const float beta =
      acosf(fminf(1.0f, fmaxf(-1.0f, -mvs::dot(from_frame, centre) / (frame_distance * baseline))));
  const float beta_plus = beta + pixel_angle;
  const float gamma = 3.14159265f - alpha - beta_plus;
  if (!(gamma > 0.0f)) return INFINITY;
  const float distance_plus = baseline * sinf(beta_plus) / sinf(gamma);  // along the ray
  return fabsf(distance_plus - point_distance) / point_distance * depth;  // as z-depth
}

// Combines measurement x (variance tau2) into the belief; `depth_range` is
// the outlier model's width. False when the measurement is numerically
// useless (the belief is left as it was).
AMHMVS_HD bool updateBelief(DepthBelief* belief, float x, float tau2, float depth_range) {
  const float mu = belief->mu, sigma2 = belief->sigma2, a = belief->a, b = belief->b;
  const float spread2 = sigma2 + tau2;
  const float s2 = 1.0f / (1.0f / sigma2 + 1.0f / tau2);
  const float m = s2 * (mu / sigma2 + x / tau2);
  const float gauss = expf(-0.5f * (x - mu) * (x - mu) / spread2) / sqrtf(2.0f * 3.14159265f * spread2);
  float c1 = a / (a + b) * gauss;
  float c2 = b / (a + b) / depth_range;
  const float norm = c1 + c2;
  if (!(norm > 0.0f)) return false;
  c1 /= norm;
  c2 /= norm;
  const float f = c1 * (a + 1.0f) / (a + b + 1.0f) + c2 * a / (a + b + 1.0f);
  const float e = c1 * (a + 1.0f) * (a + 2.0f) / ((a + b + 1.0f) * (a + b + 2.0f)) +
                  c2 * a * (a + 1.0f) / ((a + b + 1.0f) * (a + b + 2.0f));
  const float mu_new = c1 * m + c2 * mu;
  const float sigma2_new = c1 * (s2 + m * m) + c2 * (sigma2 + mu * mu) - mu_new * mu_new;
  const float a_new = (e - f) / (f - e / f);
  const float b_new = a_new * (1.0f - f) / f;
  if (!(sigma2_new > 0.0f) || !(a_new > 0.0f) || !(b_new > 0.0f) || !mvs::isfinite_hd(mu_new)) return false;
  *belief = {mu_new, sigma2_new, a_new, b_new};
  return true;
}

// A frame that sees the pixel but matches nowhere near the belief: evidence
// of an outlier (REMODE and SVO count it in b).
AMHMVS_HD void countMiss(DepthBelief* belief) { belief->b += 1.0f; }

struct SearchParams {
  mvs::CostParams cost;
  int samples;        // depths tried, uniform in inverse depth over the interval
  float max_cost;     // a match needs a cost below this
};

enum class SearchOutcome { kNotVisible, kNoMatch, kMatch };

// Searches pixel (x, y)'s epipolar segment between depths near and far in the
// frame of geometry `g` for the depth whose window (the plane of `normal`
// through that depth) matches best; refined between samples by a parabola
// in the sample index; kNoMatch when the best cost is not below max_cost or
// lies at an end of the segment. kNotVisible when the segment's middle projects
// outside the frame or behind it.
template <class Window, class SourceView, class Samples>
AMHMVS_HD SearchOutcome searchEpipolar(const SourceView& frame, const SearchParams& p, const Intrinsics& k,
                                       const SourceGeometry& g, const mvs::ReferenceWindowT<Samples>& win, Vec3 normal,
                                       int x, int y, float near, float far, float* depth, float* cost) {
  const Vec3 ray = mvs::pixelRay(k, static_cast<float>(x), static_cast<float>(y));
  const float inv_near = 1.0f / near, inv_far = 1.0f / far;
  {
    const float middle = 2.0f / (inv_near + inv_far);
    // K_f (R X + t) = A (depth (x, y, 1)) + b for X = depth K_r^-1 (x, y, 1).
    const Vec3 seen = mvs::mul(g.A, middle * Vec3{static_cast<float>(x), static_cast<float>(y), 1.0f}) + g.b;
    if (!(seen.z > 0.0f)) return SearchOutcome::kNotVisible;
    const float u = seen.x / seen.z, v = seen.y / seen.z;
    if (!(u >= 0.0f && v >= 0.0f && u <= g.width - 1.0f && v <= g.height - 1.0f)) return SearchOutcome::kNotVisible;
  }
  float best = mvs::kMaxCost, before = mvs::kMaxCost, after = mvs::kMaxCost, previous = mvs::kMaxCost;
  int best_index = -1;
  const int n = p.samples > 1 ? p.samples : 2;
  for (int i = 0; i < n; ++i) {
    const float inv = inv_near + (inv_far - inv_near) * static_cast<float>(i) / static_cast<float>(n - 1);
    const Plane plane = mvs::planeFromDepthNormal(normal, 1.0f / inv, ray);
    const float c = mvs::windowCost<Window>(frame, p.cost, win, mvs::windowHomography(g, mvs::planeTerm(k, plane)),
                                            x, y);
    if (c < best) {
      best = c;
      best_index = i;
      before = previous;
      after = mvs::kMaxCost;
    } else if (i == best_index + 1) {
      after = c;
    }
    previous = c;
  }
  // A best match at an end of the segment is no minimum: the cost falls on
  // beyond it, and taking it would walk the belief there a step at a time.
  if (best_index <= 0 || best_index >= n - 1 || !(best < p.max_cost)) return SearchOutcome::kNoMatch;
  float offset = 0.0f;
  const float curvature = before - 2.0f * best + after;
  if (curvature > 0.0f) offset = 0.5f * (before - after) / curvature;
  const float inv = inv_near + (inv_far - inv_near) * (static_cast<float>(best_index) + offset) / static_cast<float>(n - 1);
  *depth = 1.0f / inv;
  *cost = best;
  return SearchOutcome::kMatch;
}

// What one frame measures at one pixel (the per-frame constants).
struct FrameParams {
  SearchParams search;
  Intrinsics keyframe;    // the keyframe's intrinsics
  SourceGeometry frame;   // the frame relative to the keyframe
  Vec3 frame_centre;      // the frame's centre in the keyframe's camera frame
  float pixel_angle;      // a measurement's matching error as an angle, radians
  float search_sigmas;    // the segment: +- this many sigma around the belief
  float depth_range;      // the outlier model's width
};

enum class PixelOutcome { kSkipped, kNotVisible, kMissed, kMatched };

// One pixel of one frame, for both backends: the keyframe's window at (x, y)
// (its reference image in `keyframe`), the search along the frame's
// epipolar segment around the belief, and the belief's update: a match
// updates it, a visible miss counts against it, no parallax or no texture
// leaves it as it was.
template <class Window, class Sampler, class SourceView, class Samples>
AMHMVS_HD PixelOutcome filterPixel(const Sampler& keyframe, const SourceView& frame, const FrameParams& p, Vec3 normal,
                                   int x, int y, mvs::ReferenceWindowT<Samples>* window, DepthBelief* belief) {
  if (!(belief->sigma2 > 0.0f)) return PixelOutcome::kSkipped;  // no estimate here
  mvs::computeReferenceWindow<Window>(keyframe, p.search.cost, x, y, window);
  if (!window->textured) return PixelOutcome::kSkipped;
  const float sigma = sqrtf(belief->sigma2);
  const float near = fmaxf(0.5f * belief->mu, belief->mu - p.search_sigmas * sigma);
  const float far = belief->mu + p.search_sigmas * sigma;
  float depth = 0.0f, cost = 0.0f;
  const SearchOutcome found =
      searchEpipolar<Window>(frame, p.search, p.keyframe, p.frame, *window, normal, x, y, near, far, &depth, &cost);
  if (found == SearchOutcome::kNotVisible) return PixelOutcome::kNotVisible;
  if (found == SearchOutcome::kNoMatch) {
    countMiss(belief);
    return PixelOutcome::kMissed;
  }
  const float tau = measurementSigma(mvs::pixelRay(p.keyframe, static_cast<float>(x), static_cast<float>(y)), depth,
                                     p.frame_centre, p.pixel_angle);
  // No parallax: the frame tells nothing about the depth.
  if (!mvs::isfinite_hd(tau) || !updateBelief(belief, depth, tau * tau, p.depth_range)) return PixelOutcome::kNotVisible;
  return PixelOutcome::kMatched;
}

}  // namespace filter
}  // namespace amhmvs
