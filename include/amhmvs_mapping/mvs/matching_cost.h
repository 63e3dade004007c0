// Bilaterally weighted NCC matching cost (paper eq. 15).
//
//   m(p, h(p)) = 1 - cov(p, h(p)) / sqrt(cov(p, p) cov(h(p), h(p)))
//
// with weighted means E(x) = sum w_i x_i / sum w_i over an 11x11 window
// sampled every other row and column ("skipping"), and bilateral weights from
// the reference image only:
//
//   w_i = exp(-|I_i - I_c| / (2 sigma_I^2) - |x_i - x_c| / (2 sigma_x^2)).
//
// The reference window's weights and moments depend on the pixel alone, so
// they are computed once per pixel (ReferenceWindow) and reused for every
// hypothesis and view. The source window is the reference window mapped by
// the plane-induced homography H = K_s (R - t n^T / d) K_r^-1, built once per
// (hypothesis, view) and stepped incrementally across the samples.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

// Rows of the window that one trip of windowCost's row loop covers on the
// GPU. The whole window unrolled (6 rows of 6 samples) would need 185
// registers; the update kernel's launch bounds cap it at 128, which left few
// texture fetches in flight. Two rows per trip need 124 and run fountain
// x0.25 in 15.7 instead of 19.0 ms (H100; H200: one row 15.8, two 15.5,
// three 16.3; scripts/gpu_machine/gpu_check.sh step "variants" sets
// -DAMHMVS_WINDOW_ROW_UNROLL=N). Same arithmetic in the same order: same
// results. The CPU build leaves the loop to the compiler.
#ifndef AMHMVS_WINDOW_ROW_UNROLL
#define AMHMVS_WINDOW_ROW_UNROLL 2
#endif
constexpr int kWindowRowUnroll = AMHMVS_WINDOW_ROW_UNROLL;

constexpr float kMaxCost = 2.0f;
// Below this weighted variance (intensities 0..255) a window has no texture
// and the cost is undefined: kMaxCost.
constexpr float kMinVariance = 1e-5f;
constexpr int kMaxWindowSamples = 64;

struct CostParams {
  int window_radius;
  int window_step;
  float sigma_color;
  float sigma_spatial;
};

// Window shape: known at compile time for the paper's 11x11 window with
// skipping (loops unroll, per-sample arrays stay in registers), or read from
// CostParams at run time for any other option values.
template <int kRadius, int kStep>
struct FixedWindow {
  AMHMVS_HD explicit FixedWindow(const CostParams&) {}
  AMHMVS_HD static constexpr int radius() { return kRadius; }
  AMHMVS_HD static constexpr int step() { return kStep; }
  AMHMVS_HD static constexpr int perAxis() { return 2 * kRadius / kStep + 1; }
};
using PaperWindow = FixedWindow<5, 2>;

struct RuntimeWindow {
  int radius_, step_;
  AMHMVS_HD explicit RuntimeWindow(const CostParams& p) : radius_(p.window_radius), step_(p.window_step) {}
  AMHMVS_HD int radius() const { return radius_; }
  AMHMVS_HD int step() const { return step_; }
  AMHMVS_HD int perAxis() const { return 2 * radius_ / step_ + 1; }
};

inline bool isPaperWindow(const CostParams& p) {
  return p.window_radius == PaperWindow::radius() && p.window_step == PaperWindow::step();
}

// Geometry of one source view relative to the reference camera:
// A = K_s R K_r^-1 and b = K_s t, so that H = A - b q^T with q = K_r^-T n / d.
struct SourceGeometry {
  Mat3 A;
  Vec3 b;
  float width, height;  // in pixels
  int layer;            // which image of the sampler: the view index (CPU) or its pool slot (CUDA)
};

// One reference window sample: its normalised weight and the weight times
// the centred intensity, side by side so one 8-byte load fetches both.
struct WindowSample {
  float weight;          // w_i / sum w (sum = 1)
  float weighted_value;  // w_i (I_i - I_c)
};

// Where a window's samples live. By default inside the window (registers or
// the stack); the CUDA backend can hand in a slice of shared memory instead
// (see cuda_backend.cu), which frees registers for more resident warps.
struct InlineSamples {
  WindowSample s[kMaxWindowSamples];
  AMHMVS_HD WindowSample& operator[](int i) { return s[i]; }
  AMHMVS_HD const WindowSample& operator[](int i) const { return s[i]; }
};

template <class Samples>
struct ReferenceWindowT {
  int count;                             // samples in the window
  Samples sample;
  float mean, variance;                  // weighted moments of I_i - I_c
  bool textured;                         // variance >= kMinVariance
};
using ReferenceWindow = ReferenceWindowT<InlineSamples>;

template <class Window, class Sampler, class Samples>
AMHMVS_HD void computeReferenceWindow(const Sampler& sampler, const CostParams& p, int x, int y,
                                      ReferenceWindowT<Samples>* win) {
  const Window shape(p);
  const float centre = sampler.reference(x, y);
  const float color_scale = 1.0f / (2.0f * p.sigma_color * p.sigma_color);
  const float spatial_scale = 1.0f / (2.0f * p.sigma_spatial * p.sigma_spatial);
  int n = 0;
  float weight_sum = 0.0f;
  AMHMVS_UNROLL
  for (int iy = 0; iy < shape.perAxis(); ++iy) {
    const int dy = -shape.radius() + iy * shape.step();
    AMHMVS_UNROLL
    for (int ix = 0; ix < shape.perAxis(); ++ix) {
      const int dx = -shape.radius() + ix * shape.step();
      const float intensity = sampler.reference(x + dx, y + dy);
      // Samples outside the reference image weigh nothing: there is nothing
      // there to match (clamping would invent a texture the sources lack).
      const bool inside = intensity >= 0.0f;
      const float v = inside ? intensity - centre : 0.0f;
      const float w = inside ? expf(-fabsf(v) * color_scale -
                                    sqrtf(static_cast<float>(dx * dx + dy * dy)) * spatial_scale)
                             : 0.0f;
      // weighted_value holds the plain value until the weights are normalised.
      win->sample[n] = {w, v};
      weight_sum += w;
      ++n;
    }
  }
  win->count = n;
  float mean = 0.0f;
  AMHMVS_UNROLL
  for (int i = 0; i < n; ++i) {
    win->sample[i].weight /= weight_sum;
    mean += win->sample[i].weight * win->sample[i].weighted_value;
  }
  float variance = 0.0f;  // two-pass: exact for flat windows
  AMHMVS_UNROLL
  for (int i = 0; i < n; ++i) {
    const float c = win->sample[i].weighted_value - mean;
    variance += win->sample[i].weight * c * c;
    win->sample[i].weighted_value *= win->sample[i].weight;
  }
  win->mean = mean;
  win->variance = variance;
  win->textured = variance >= kMinVariance;
}

// q = K_r^-T n / d: the homography's plane term for hypothesis `plane`.
AMHMVS_HD Vec3 planeTerm(const Intrinsics& k, const Plane& plane) {
  const float inv_d = 1.0f / plane.d;
  return {plane.n.x / k.fx * inv_d, plane.n.y / k.fy * inv_d,
          (plane.n.z - plane.n.x * k.cx / k.fx - plane.n.y * k.cy / k.fy) * inv_d};
}

// Per-lane operations of the float type F that windowCost runs on: here
// F = float (GPU, scalar CPU); cpu_lanes.h specialises it for the CPU's SIMD
// lanes. Masks are what F's comparisons return.
template <class F>
struct LaneMath;

template <>
struct LaneMath<float> {
  static AMHMVS_HD float splat(float v) { return v; }
  static AMHMVS_HD bool any(bool mask) { return mask; }
  static AMHMVS_HD float select(bool mask, float a, float b) { return mask ? a : b; }
  static AMHMVS_HD float reciprocal(float x) { return mvs::reciprocal(x); }
  static AMHMVS_HD float sqrt(float x) { return sqrtf(x); }
};

template <class F>
AMHMVS_HD F dot3(F a0, F a1, F a2, float b0, float b1, float b2) {
  return a0 * b0 + a1 * b1 + a2 * b2;
}

// The plane-induced homography H = A - b q^T (row-major) of one source view
// and hypothesis, with that view's size. F = float, or on the CPU one
// (hypothesis, view) pair per lane.
template <class F>
struct WindowHomography {
  F h[9];
  F width, height;
};

// The homography of one source view for plane term q.
AMHMVS_HD WindowHomography<float> windowHomography(const SourceGeometry& g, Vec3 q) {
  const float b[3] = {g.b.x, g.b.y, g.b.z};
  WindowHomography<float> H;
  AMHMVS_UNROLL
  for (int r = 0; r < 3; ++r) {
    H.h[3 * r + 0] = g.A.m[3 * r + 0] - b[r] * q.x;
    H.h[3 * r + 1] = g.A.m[3 * r + 1] - b[r] * q.y;
    H.h[3 * r + 2] = g.A.m[3 * r + 2] - b[r] * q.z;
  }
  H.width = g.width;
  H.height = g.height;
  return H;
}

// The cost of eq. 15 for a textured reference window `win` at pixel (x, y)
// against the source window that H maps it to (its image: `source`).
// kMaxCost when the window centre maps outside the source image, when the
// point is behind the source camera, or when the source window is flat.
template <class Window, class F, class SourceView, class Samples>
AMHMVS_HD F windowCost(const SourceView& source, const CostParams& p,
                       const ReferenceWindowT<Samples>& win, const WindowHomography<F>& H, int x,
                       int y) {
  using M = LaneMath<F>;
  const Window shape(p);
  const float px = static_cast<float>(x), py = static_cast<float>(y);
  const F cz = dot3(H.h[6], H.h[7], H.h[8], px, py, 1.0f);
  const auto in_front = cz > 0.0f;  // else behind the source camera
  if (!M::any(in_front)) return M::splat(kMaxCost);
  const F cu = dot3(H.h[0], H.h[1], H.h[2], px, py, 1.0f) / cz;
  const F cv = dot3(H.h[3], H.h[4], H.h[5], px, py, 1.0f) / cz;
  const auto valid = in_front && (cu >= -0.5f && cv >= -0.5f && cu < H.width - 0.5f &&
                                  cv < H.height - 0.5f);
  if (!M::any(valid)) return M::splat(kMaxCost);
  // Source samples are centred on the value at the window centre: keeps the
  // float moments accurate for weakly textured windows.
  const F shift = source.sample(cu, cv);
  F sum_s{}, sum_ss{}, sum_rs{};
#if defined(__CUDACC__)
#pragma unroll kWindowRowUnroll
#endif
  for (int iy = 0; iy < shape.perAxis(); ++iy) {
    const int dy = -shape.radius() + iy * shape.step();
    // Homogeneous source point of the row start, then stepped along x.
    const float row_x = px - shape.radius(), row_y = py + dy;
    F hx = dot3(H.h[0], H.h[1], H.h[2], row_x, row_y, 1.0f);
    F hy = dot3(H.h[3], H.h[4], H.h[5], row_x, row_y, 1.0f);
    F hz = dot3(H.h[6], H.h[7], H.h[8], row_x, row_y, 1.0f);
    const float step = static_cast<float>(shape.step());
    const F step_x = H.h[0] * step, step_y = H.h[3] * step, step_z = H.h[6] * step;
    AMHMVS_UNROLL
    for (int ix = 0; ix < shape.perAxis(); ++ix) {
      const int i = iy * shape.perAxis() + ix;
      const F inv_z = M::reciprocal(hz);
      const F s = source.sample(hx * inv_z, hy * inv_z) - shift;
      const WindowSample r = win.sample[i];
      sum_s += r.weight * s;
      sum_ss += r.weight * s * s;
      sum_rs += r.weighted_value * s;
      hx += step_x;
      hy += step_y;
      hz += step_z;
    }
  }
  const F var_s = sum_ss - sum_s * sum_s;
  const auto scored = valid && var_s >= kMinVariance;
  if (!M::any(scored)) return M::splat(kMaxCost);
  const F covariance = sum_rs - win.mean * sum_s;
  const F ncc = covariance / M::sqrt(win.variance * var_s);
  const F cost = 1.0f - ncc;
  const F max_cost = M::splat(kMaxCost);
  const F clamped =
      M::select(cost < 0.0f, M::splat(0.0f), M::select(cost < kMaxCost, cost, max_cost));
  return M::select(scored, clamped, max_cost);
}

// Cost of hypothesis `plane` (plane term q = planeTerm(K, plane)) at
// reference pixel (x, y) against the source view of geometry `g` (its image:
// sampler.sourceView(g.layer)). kMaxCost also when the reference window is
// textureless.
template <class Window, class Sampler, class Samples>
AMHMVS_HD float matchingCost(const Sampler& sampler, const CostParams& p,
                             const ReferenceWindowT<Samples>& win, const SourceGeometry& g,
                             Vec3 q, int x, int y) {
  if (!win.textured) return kMaxCost;
  return windowCost<Window>(sampler.sourceView(g.layer), p, win,
                            windowHomography(g, q), x, y);
}

// The matching costs one pixel needs, evaluated as its sampler prefers: each
// at once (Sampler::kLanes == 1: the GPU, where a thread per pixel already
// fills the machine), or Sampler::kLanes per pass over the window (the CPU's
// SIMD lanes, see CpuSampler::laneCosts). add() may write its result only at
// the next add() or flush().
template <class Window, class Sampler, class Samples, int kLanes = Sampler::kLanes>
class CostBatch {
 public:
  CostBatch(const Sampler& sampler, const CostParams& p, const ReferenceWindowT<Samples>& win,
            int x, int y)
      : sampler_(sampler), p_(p), win_(win), x_(x), y_(y) {}

  void add(const SourceGeometry& g, Vec3 q, float* out) {
    if (!win_.textured) {
      *out = kMaxCost;
      return;
    }
    geometry_[count_] = &g;
    q_[count_] = q;
    out_[count_] = out;
    if (++count_ == kLanes) flush();
  }
  void flush() {
    if (count_ == 0) return;
    for (int l = count_; l < kLanes; ++l) {  // idle lanes repeat lane 0
      geometry_[l] = geometry_[0];
      q_[l] = q_[0];
    }
    float costs[kLanes];
    sampler_.template laneCosts<Window>(p_, win_, geometry_, q_, x_, y_, costs);
    for (int l = 0; l < count_; ++l) *out_[l] = costs[l];
    count_ = 0;
  }

 private:
  const Sampler& sampler_;
  const CostParams& p_;
  const ReferenceWindowT<Samples>& win_;
  int x_, y_;
  int count_ = 0;
  const SourceGeometry* geometry_[kLanes];
  Vec3 q_[kLanes];
  float* out_[kLanes];
};

template <class Window, class Sampler, class Samples>
class CostBatch<Window, Sampler, Samples, 1> {
 public:
  AMHMVS_HD CostBatch(const Sampler& sampler, const CostParams& p,
                      const ReferenceWindowT<Samples>& win, int x, int y)
      : sampler_(sampler), p_(p), win_(win), x_(x), y_(y) {}
  AMHMVS_HD void add(const SourceGeometry& g, Vec3 q, float* out) {
    *out = matchingCost<Window>(sampler_, p_, win_, g, q, x_, y_);
  }
  AMHMVS_HD void flush() {}

 private:
  const Sampler& sampler_;
  const CostParams& p_;
  const ReferenceWindowT<Samples>& win_;
  int x_, y_;
};

}  // namespace mvs
}  // namespace amhmvs
