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

// Cost of hypothesis `plane` at reference pixel (x, y) against the source view
// of geometry `g` (its image: sampler.sourceView(g.layer)).
// kMaxCost when either window is textureless, when the window centre maps
// outside the source image, or when the point is behind the source camera.
template <class Window, class Sampler, class Samples>
AMHMVS_HD float matchingCost(const Sampler& sampler, const CostParams& p,
                             const ReferenceWindowT<Samples>& win, const SourceGeometry& g,
                             Vec3 q, int x, int y) {
  if (!win.textured) return kMaxCost;
  const Window shape(p);
  // Rows of H = A - b q^T.
  const Vec3 h0 = {g.A.m[0] - g.b.x * q.x, g.A.m[1] - g.b.x * q.y, g.A.m[2] - g.b.x * q.z};
  const Vec3 h1 = {g.A.m[3] - g.b.y * q.x, g.A.m[4] - g.b.y * q.y, g.A.m[5] - g.b.y * q.z};
  const Vec3 h2 = {g.A.m[6] - g.b.z * q.x, g.A.m[7] - g.b.z * q.y, g.A.m[8] - g.b.z * q.z};
  const Vec3 pc = {static_cast<float>(x), static_cast<float>(y), 1.0f};
  const float cz = dot(h2, pc);
  if (!(cz > 0.0f)) return kMaxCost;  // behind the source camera
  const float cu = dot(h0, pc) / cz, cv = dot(h1, pc) / cz;
  if (!(cu >= -0.5f && cv >= -0.5f && cu < g.width - 0.5f && cv < g.height - 0.5f)) {
    return kMaxCost;
  }
  // Source samples are centred on the value at the window centre: keeps the
  // float moments accurate for weakly textured windows.
  const auto source = sampler.sourceView(g.layer);
  const float shift = source.sample(cu, cv);
  float sum_s = 0.0f, sum_ss = 0.0f, sum_rs = 0.0f;
  AMHMVS_UNROLL
  for (int iy = 0; iy < shape.perAxis(); ++iy) {
    const int dy = -shape.radius() + iy * shape.step();
    // Homogeneous source point of the row start, then stepped along x.
    const Vec3 row = {pc.x - shape.radius(), pc.y + dy, 1.0f};
    float hx = dot(h0, row), hy = dot(h1, row), hz = dot(h2, row);
    const float step_x = h0.x * shape.step(), step_y = h1.x * shape.step(),
                step_z = h2.x * shape.step();
    AMHMVS_UNROLL
    for (int ix = 0; ix < shape.perAxis(); ++ix) {
      const int i = iy * shape.perAxis() + ix;
      const float inv_z = reciprocal(hz);
      const float s = source.sample(hx * inv_z, hy * inv_z) - shift;
      const WindowSample r = win.sample[i];
      sum_s += r.weight * s;
      sum_ss += r.weight * s * s;
      sum_rs += r.weighted_value * s;
      hx += step_x;
      hy += step_y;
      hz += step_z;
    }
  }
  const float var_s = sum_ss - sum_s * sum_s;
  if (!(var_s >= kMinVariance)) return kMaxCost;
  const float covariance = sum_rs - win.mean * sum_s;
  const float ncc = covariance / sqrtf(win.variance * var_s);
  const float cost = 1.0f - ncc;
  return cost < 0.0f ? 0.0f : (cost < kMaxCost ? cost : kMaxCost);
}

}  // namespace mvs
}  // namespace amhmvs
