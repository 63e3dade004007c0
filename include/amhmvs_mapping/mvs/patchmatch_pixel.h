// The AMHMVS per-pixel algorithm, written once for both backends.
//
// Each function here handles one reference pixel and is called by the CPU
// backend (OpenMP loops over pixels) and the CUDA backend (one thread per
// pixel) with a backend-specific Sampler:
//
//   float Sampler::reference(int x, int y) const;    // 0..255, -1 outside
//   SourceView Sampler::sourceView(int view) const;  // per source view:
//   float SourceView::sample(float x, float y) const;  // bilinear, 0..255
//
// Schedule (paper section 3 and 4): random initialisation, then per iteration
// a black and a red checkerboard pass; each pass runs, at every pixel of its
// colour: propagation (section 3.1) -> cost matrix (eq. 8) -> joint view
// selection (eqs. 9-14) -> best hypothesis -> refinement (section 3.3).
// After the last iteration the depth map is median filtered.
#pragma once

#include "amhmvs_mapping/mvs/geometric_consistency.h"
#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/matching_cost.h"
#include "amhmvs_mapping/mvs/planar_prior_pixel.h"
#include "amhmvs_mapping/mvs/propagation_pattern.h"
#include "amhmvs_mapping/mvs/random.h"
#include "amhmvs_mapping/mvs/view_selection.h"

namespace amhmvs {
namespace mvs {

// Everything a pass needs besides images and per-pixel state; plain data so it
// can be passed by value to a CUDA kernel.
struct PatchMatchParams {
  int width, height;
  int num_sources;
  Intrinsics K;
  float depth_min, depth_max;
  float min_normal_cos;  // cosine of the steepest accepted hypothesis
  uint32_t seed;
  bool heuristic_view_selection;
  int bisection_only_iterations;
  int bisection_steps;
  float perturbation;
  CostParams cost;
  SelectionParams selection;
  PropagationPattern pattern;
  SourceGeometry sources[32];
  int first_iteration;  // number of the first iteration (schedules depend on it)
  // Geometric consistency (geometric_consistency.h), with the source views'
  // depth maps concatenated (device memory on the GPU).
  GeometricTerm geometric;
  SourceBackprojection back[32];
  const float* source_depths;
  // Start from this depth (1 per pixel) and normal (3 per pixel) map instead
  // of random planes where they are valid; null: random start.
  const float* prior_depth;
  const float* prior_normal;
  // The planar prior's term (planar_prior_pixel.h; depth null: off).
  PlanarPriorTerm planar;
  float unscored_cost;  // a pixel's cost at or above this: nothing could be scored
};

// Calls run(WindowType<W>()) with W the window shape of P's cost options
// (the paper's, compiled in, or any at run time).
template <class Window>
struct WindowType {
  using type = Window;
};
template <class Run>
void withWindowType(const PatchMatchParams& P, Run&& run) {
  if (isPaperWindow(P.cost)) run(WindowType<PaperWindow>());
  else run(WindowType<RuntimeWindow>());
}

// Per-pixel state in structure-of-arrays form (device or host pointers).
struct PixelState {
  Plane* plane;
  float* cost;
  uint32_t* selected;   // views weighted in the last iteration (mask)
  int8_t* best_view;    // most important view of the last iteration, or -1
};

// Random streams: one per use, so draws never overlap between stages.
enum RandomStream : uint32_t { kStreamInit = 0, kStreamIterationBase = 1 };

AMHMVS_HD bool acceptableHypothesis(const PatchMatchParams& P, const Plane& plane, Vec3 ray,
                                    float* depth_out) {
  const float depth = planeDepth(plane, ray);
  *depth_out = depth;
  if (!(depth >= P.depth_min && depth <= P.depth_max)) return false;
  // Reject planes seen at grazing angles: their homographies are degenerate.
  const float cos_angle = -dot(plane.n, ray) * rsqrtf_hd(dot(ray, ray));
  return cos_angle >= P.min_normal_cos;
}

AMHMVS_HD Vec3 randomUnitVector(PixelRandom* rng) {
  // Uniform on the sphere: uniform z and azimuth.
  const float z = rng->uniform(-1.0f, 1.0f);
  const float phi = rng->uniform(0.0f, 6.28318530718f);
  const float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
  return {r * cosf(phi), r * sinf(phi), z};
}

// Flip n to face the camera along `ray`.
AMHMVS_HD Vec3 facingCamera(Vec3 n, Vec3 ray) { return dot(n, ray) > 0.0f ? -1.0f * n : n; }

AMHMVS_HD Vec3 randomNormal(const PatchMatchParams& P, Vec3 ray, PixelRandom* rng) {
  const Vec3 unit_ray = normalized(ray);
  for (int attempt = 0; attempt < 8; ++attempt) {
    const Vec3 n = facingCamera(randomUnitVector(rng), ray);
    if (-dot(n, unit_ray) >= P.min_normal_cos) return n;
  }
  return -1.0f * unit_ray;  // fronto-parallel
}

// Normal n moved by a random offset of size `scale`, still facing the camera
// and not steeper than allowed (else n itself).
AMHMVS_HD Vec3 perturbNormal(const PatchMatchParams& P, Vec3 n, Vec3 ray, float scale,
                             PixelRandom* rng) {
  const Vec3 offset = {rng->uniform(-scale, scale), rng->uniform(-scale, scale),
                       rng->uniform(-scale, scale)};
  const Vec3 candidate = facingCamera(normalized(n + offset), ray);
  return -dot(candidate, normalized(ray)) >= P.min_normal_cos ? candidate : n;
}

// Adds the geometric term to the costs of views[0..count) (all views when
// `views` is null) of `plane` at (x, y).
AMHMVS_HD void addGeometricCosts(const PatchMatchParams& P, const SourceGeometry* sources,
                                 const int8_t* views, int count, const Plane& plane, int x, int y,
                                 float* costs) {
  if (!P.geometric.enabled) return;
  const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
  for (int k = 0; k < count; ++k) {
    const int j = views ? views[k] : k;
    costs[j] += P.geometric.weight * reprojectionError(P.geometric, sources[j], P.back[j],
                                                       P.source_depths, plane, ray, x, y);
  }
}

// A hypothesis's cost beyond its matching cost: the planar prior's term, 0
// without one.
AMHMVS_HD float priorCost(const PatchMatchParams& P, const Plane& plane, int x, int y) {
  if (!P.planar.depth) return 0.0f;
  const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
  return planarPriorCost(P.planar, y * P.width + x, planeDepth(plane, ray), plane.n);
}

// The start's plane at pixel `index` when it is usable, else false.
AMHMVS_HD bool priorPlane(const PatchMatchParams& P, int index, Vec3 ray, Plane* plane) {
  if (!P.prior_depth) return false;
  const float depth = P.prior_depth[index];
  const Vec3 n = {P.prior_normal[3 * index], P.prior_normal[3 * index + 1], P.prior_normal[3 * index + 2]};
  if (!(depth >= P.depth_min && depth <= P.depth_max) || !(dot(n, n) > 0.5f)) return false;
  *plane = planeFromDepthNormal(n, depth, ray);
  float d;
  return acceptableHypothesis(P, *plane, ray, &d);
}

// --- Initialisation -------------------------------------------------------

// Random plane (uniform depth in range, random normal facing the camera) and
// its initial cost: the heuristic aggregation over all views (no selection
// exists yet).
template <class Window, class Sampler, class Samples = InlineSamples>
AMHMVS_HD void initializePixel(const PatchMatchParams& P, const Sampler& sampler,
                               PixelState state, int x, int y, Samples samples = Samples()) {
  const int index = y * P.width + x;
  PixelRandom rng(P.seed, static_cast<uint32_t>(index), kStreamInit);
  const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
  const float depth = rng.uniform(P.depth_min, P.depth_max);
  Plane plane = planeFromDepthNormal(randomNormal(P, ray, &rng), depth, ray);
  priorPlane(P, index, ray, &plane);  // replaces the random plane where usable

  ReferenceWindowT<Samples> win;
  win.sample = samples;
  computeReferenceWindow<Window>(sampler, P.cost, x, y, &win);
  const Vec3 q = planeTerm(P.K, plane);
  float costs[32];
  CostBatch<Window, Sampler, Samples> batch(sampler, P.cost, win, x, y);
  for (int j = 0; j < P.num_sources; ++j) batch.add(P.sources[j], q, &costs[j]);
  batch.flush();
  addGeometricCosts(P, P.sources, nullptr, P.num_sources, plane, x, y, costs);
  ViewWeights heuristic;
  heuristic.heuristic = true;
  state.plane[index] = plane;
  state.cost[index] = aggregateCost(P.selection, heuristic, costs, P.num_sources) + priorCost(P, plane, x, y);
  state.selected[index] = 0;
  state.best_view[index] = kNoView;
}

// --- One checkerboard update ------------------------------------------------

// Views a hypothesis is scored on: those with weight (all in heuristic mode),
// ascending. A compact list keeps the threads of a GPU warp in step: each
// loops over its own few views instead of all threads over every view that
// any of them needs.
struct ViewList {
  int count;
  int8_t view[32];
};

AMHMVS_HD void listNeededViews(const ViewWeights& weights, int num_views, ViewList* list) {
  list->count = 0;
  for (int j = 0; j < num_views; ++j) {
    if (needsView(weights, j)) list->view[list->count++] = static_cast<int8_t>(j);
  }
}

// Scores `plane` at the pixel with the pixel's view weights (eq. 14): costs
// of the listed views only; the others carry no weight and are not read.
template <class Window, class Sampler, class Samples>
AMHMVS_HD float scoreHypothesis(const PatchMatchParams& P, const SourceGeometry* sources,
                                const Sampler& sampler, const ReferenceWindowT<Samples>& win,
                                const ViewWeights& weights, const ViewList& views,
                                const Plane& plane, int x, int y) {
  const Vec3 q = planeTerm(P.K, plane);
  float costs[32];
  CostBatch<Window, Sampler, Samples> batch(sampler, P.cost, win, x, y);
  for (int k = 0; k < views.count; ++k) {
    const int j = views.view[k];
    batch.add(sources[j], q, &costs[j]);
  }
  batch.flush();
  addGeometricCosts(P, sources, views.view, views.count, plane, x, y, costs);
  return aggregateCost(P.selection, weights, costs, P.num_sources) + priorCost(P, plane, x, y);
}

// scoreHypothesis of `count` (<= 8) planes, their costs evaluated together
// (for samplers with SIMD lanes).
template <class Window, class Sampler, class Samples>
AMHMVS_HD void scoreHypotheses(const PatchMatchParams& P, const SourceGeometry* sources,
                               const Sampler& sampler, const ReferenceWindowT<Samples>& win,
                               const ViewWeights& weights, const ViewList& views,
                               const Plane* planes, int count, int x, int y, float* scores) {
  float costs[8][32];
  CostBatch<Window, Sampler, Samples> batch(sampler, P.cost, win, x, y);
  for (int c = 0; c < count; ++c) {
    const Vec3 q = planeTerm(P.K, planes[c]);
    for (int k = 0; k < views.count; ++k) {
      const int j = views.view[k];
      batch.add(sources[j], q, &costs[c][j]);
    }
  }
  batch.flush();
  for (int c = 0; c < count; ++c) {
    addGeometricCosts(P, sources, views.view, views.count, planes[c], x, y, costs[c]);
    scores[c] = aggregateCost(P.selection, weights, costs[c], P.num_sources) + priorCost(P, planes[c], x, y);
  }
}

// Propagation (section 3.1): per region, the candidate of lowest current cost.
// Returns the number of hypotheses written to `hypotheses`.
AMHMVS_HD int propagateCandidates(const PatchMatchParams& P, PixelState state, int x, int y,
                                  Vec3 ray, Plane* hypotheses) {
  int count = 0;
  for (int region = 0; region < kNumRegions; ++region) {
    int best = -1;
    float best_cost = 0.0f;
    for (int k = P.pattern.begin[region]; k < P.pattern.begin[region + 1]; ++k) {
      const int nx = x + P.pattern.offsets[k].dx, ny = y + P.pattern.offsets[k].dy;
      if (nx < 0 || ny < 0 || nx >= P.width || ny >= P.height) continue;
      const int n_index = ny * P.width + nx;
      const float c = state.cost[n_index];
      if (best < 0 || c < best_cost) {
        best = n_index;
        best_cost = c;
      }
    }
    if (best < 0) continue;  // no candidate inside the image
    float depth;
    const Plane candidate = state.plane[best];
    if (acceptableHypothesis(P, candidate, ray, &depth)) hypotheses[count++] = candidate;
  }
  return count;
}

// Scoring a plane twice gives the same costs. Propagation copies planes
// verbatim, so converged areas offer the same plane from several regions:
// each distinct plane is scored once and its row copied to the duplicates.
AMHMVS_HD bool samePlane(const Plane& a, const Plane& b) {
  return a.n.x == b.n.x && a.n.y == b.n.y && a.n.z == b.n.z && a.d == b.d;
}

// Index of the first of planes[0..i] equal to planes[i] (i when none before).
AMHMVS_HD int firstEqualPlane(const Plane* planes, int i) {
  for (int k = 0; k < i; ++k) {
    if (samePlane(planes[k], planes[i])) return k;
  }
  return i;
}

// Cost matrix of eq. 8, `rows` x P.num_sources, row-major with stride
// P.num_sources: every hypothesis against every source view.
template <class Window, class Sampler, class Samples>
AMHMVS_HD void costMatrix(const PatchMatchParams& P, const SourceGeometry* sources,
                          const Sampler& sampler, const ReferenceWindowT<Samples>& win,
                          const Plane* hypotheses, int rows, int x, int y, float* matrix) {
  const int n = P.num_sources;
  int first[kNumRegions];
  int distinct[kNumRegions];
  int num_distinct = 0;
  for (int i = 0; i < rows; ++i) {
    first[i] = firstEqualPlane(hypotheses, i);
    if (first[i] == i) distinct[num_distinct++] = i;
  }
  CostBatch<Window, Sampler, Samples> batch(sampler, P.cost, win, x, y);
  for (int k = 0; k < num_distinct; ++k) {
    const int i = distinct[k];
    const Vec3 q = planeTerm(P.K, hypotheses[i]);
    for (int j = 0; j < n; ++j) batch.add(sources[j], q, &matrix[i * n + j]);
  }
  batch.flush();
  for (int k = 0; k < num_distinct; ++k) {
    const int i = distinct[k];
    addGeometricCosts(P, sources, nullptr, n, hypotheses[i], x, y, &matrix[i * n]);
  }
  for (int i = 0; i < rows; ++i) {
    if (first[i] == i) continue;
    for (int j = 0; j < n; ++j) matrix[i * n + j] = matrix[first[i] * n + j];
  }
}

// `sources` is P.sources or a copy of it in faster memory, `samples` the
// storage of the reference window (both: GPU shared memory, see
// cuda_backend.cu).
template <class Window, class Sampler, class Samples = InlineSamples>
AMHMVS_HD void updatePixel(const PatchMatchParams& P, const SourceGeometry* sources,
                           const Sampler& sampler, PixelState state, int iteration, int x,
                           int y, Samples samples = Samples()) {
  const int index = y * P.width + x;
  const int n = P.num_sources;
  const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
  ReferenceWindowT<Samples> win;
  win.sample = samples;
  computeReferenceWindow<Window>(sampler, P.cost, x, y, &win);
  if (!win.textured) return;  // nothing can be scored here: keep the state

  // Propagated hypotheses and their cost matrix (eq. 8); one spare slot for
  // the current plane.
  Plane hypotheses[kNumRegions + 1];
  const int rows = propagateCandidates(P, state, x, y, ray, hypotheses);
  float matrix[kNumRegions * 32];
  costMatrix<Window>(P, sources, sampler, win, hypotheses, rows, x, y, matrix);

  // View weights (eqs. 9-13), or the heuristic aggregation.
  ViewWeights weights;
  if (P.heuristic_view_selection) {
    weights.heuristic = true;
    weights.selected = 0;
    weights.best_view = kNoView;
  } else {
    jointViewSelection(P.selection, matrix, rows, n, n, iteration, state.selected[index],
                       state.best_view[index], &weights);
  }
  ViewList views;
  listNeededViews(weights, n, &views);

  // Current plane, re-scored with this pass's weights, against the best
  // propagated hypothesis (eq. 14).
  Plane plane = state.plane[index];
  hypotheses[rows] = plane;
  const int same = firstEqualPlane(hypotheses, rows);
  float cost = same < rows
                   ? aggregateCost(P.selection, weights, &matrix[same * n], n) + priorCost(P, plane, x, y)
                   : scoreHypothesis<Window>(P, sources, sampler, win, weights, views, plane, x, y);
  for (int i = 0; i < rows; ++i) {
    const float c = aggregateCost(P.selection, weights, &matrix[i * n], n) + priorCost(P, hypotheses[i], x, y);
    if (c < cost) {
      cost = c;
      plane = hypotheses[i];
    }
  }

  // Refinement (section 3.3).
  PixelRandom rng(P.seed, static_cast<uint32_t>(index), kStreamIterationBase + iteration);
  float depth = planeDepth(plane, ray);
  auto tryHypothesis = [&](float candidate_depth, Vec3 candidate_normal) {
    const Plane candidate = planeFromDepthNormal(candidate_normal, candidate_depth, ray);
    float d;
    if (!acceptableHypothesis(P, candidate, ray, &d)) return;
    const float c =
        scoreHypothesis<Window>(P, sources, sampler, win, weights, views, candidate, x, y);
    if (c < cost) {
      cost = c;
      plane = candidate;
      depth = d;
    }
  };
  // Bisection (Gipuma): random samples in a depth interval and normal cone
  // that halve at every step, across steps and iterations.
  for (int s = 0; s < P.bisection_steps; ++s) {
    const float scale = ldexpf(1.0f, -(iteration + s));  // 1, 1/2, 1/4, ...
    const float half_width = 0.5f * scale * (P.depth_max - P.depth_min);
    const float candidate_depth = depth + rng.uniform(-half_width, half_width);
    tryHypothesis(candidate_depth, perturbNormal(P, plane.n, ray, scale, &rng));
  }
  // The planar prior's own plane.
  float planar_depth;
  Vec3 planar_normal;
  if (planarPriorAt(P.planar, index, &planar_depth, &planar_normal)) tryHypothesis(planar_depth, planar_normal);
  // COLMAP-style: perturbed and random depth and normal, in the combinations
  // where neither, one or both of the current values are close to the truth.
  if (iteration >= P.bisection_only_iterations) {
    const Vec3 n = plane.n;
    const float z = depth;
    const float z_perturbed = z * (1.0f + rng.uniform(-P.perturbation, P.perturbation));
    const Vec3 n_perturbed = perturbNormal(P, n, ray, P.perturbation, &rng);
    const float z_random = rng.uniform(P.depth_min, P.depth_max);
    const Vec3 n_random = randomNormal(P, ray, &rng);
    const float depths[5] = {z_perturbed, z, z_random, z, z_perturbed};
    const Vec3 normals[5] = {n, n_perturbed, n, n_random, n_perturbed};
    if constexpr (Sampler::kLanes == 1) {
      for (int c = 0; c < 5; ++c) tryHypothesis(depths[c], normals[c]);
    } else {
      // SIMD lanes (CPU): the five do not depend on each other's outcome, so
      // they are scored together, then tried in the same order.
      Plane candidates[5];
      float candidate_depths[5], scores[5];
      int held = 0;
      for (int c = 0; c < 5; ++c) {
        candidates[held] = planeFromDepthNormal(normals[c], depths[c], ray);
        if (acceptableHypothesis(P, candidates[held], ray, &candidate_depths[held])) ++held;
      }
      scoreHypotheses<Window>(P, sources, sampler, win, weights, views, candidates, held, x, y,
                              scores);
      for (int c = 0; c < held; ++c) {
        if (scores[c] < cost) {
          cost = scores[c];
          plane = candidates[c];
          depth = candidate_depths[c];
        }
      }
    }
  }

  state.plane[index] = plane;
  state.cost[index] = cost;
  state.selected[index] = weights.selected;
  state.best_view[index] = static_cast<int8_t>(weights.best_view);
}

// --- Output -----------------------------------------------------------------

// Raw depth, normal and cost of a pixel. Depth is NaN where no hypothesis
// could be scored at all (cost still kMaxCost).
AMHMVS_HD void pixelOutput(const PatchMatchParams& P, PixelState state, int x, int y,
                           float* depth, Vec3* normal, float* cost) {
  const int index = y * P.width + x;
  const Plane plane = state.plane[index];
  const Vec3 ray = pixelRay(P.K, static_cast<float>(x), static_cast<float>(y));
  // The matching cost alone: the confidence is calibrated on it.
  *cost = state.cost[index] - priorCost(P, plane, x, y);
  *normal = plane.n;
  *depth = *cost < P.unscored_cost ? planeDepth(plane, ray) : nanf_hd();
}

// Median of the finite depths in a size x size window covering offsets
// -size/2 .. (size-1)/2 (for the paper's 4x4: -2..1). The median of an even
// count is the mean of the two middle values. NaN stays NaN.
AMHMVS_HD float medianDepth(const float* depth, int width, int height, int x, int y, int size) {
  const float centre = depth[y * width + x];
  if (size <= 1 || !(centre == centre)) return centre;
  float values[64];
  int n = 0;
  const int lo = -(size / 2), hi = (size - 1) / 2;
  for (int dy = lo; dy <= hi; ++dy) {
    for (int dx = lo; dx <= hi; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
      const float v = depth[ny * width + nx];
      if (!(v == v)) continue;
      // Insertion sort: at most 64 values.
      int k = n++;
      while (k > 0 && values[k - 1] > v) {
        values[k] = values[k - 1];
        --k;
      }
      values[k] = v;
    }
  }
  return (n % 2) ? values[n / 2] : 0.5f * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace mvs
}  // namespace amhmvs
