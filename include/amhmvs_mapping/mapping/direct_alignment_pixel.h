// One point's term of the direct (photometric) alignment of a source view to
// the reference (mapping/direct_alignment.h), written once for the CPU and
// the CUDA backend (mvs/hd.h).
//
// A source pixel with depth is the point X (source camera frame) of grey
// level I_s. Moved into the reference by the relative pose (R, t) and seen at
// u = pi(R X + t), its residual is
//
//   r = I_r(u) - (exp(a) I_s + b)
//
// with the affine brightness change (a, b) between the two exposures. The
// Jacobian is taken for a left increment of the pose, X' = X + v + w x X
// (X here in the reference frame), and for a and b:
//
//   dr/dv = g^T dpi/dX,   dr/dw = X x (dr/dv),   dr/da = -exp(a) I_s,   dr/db = -1
//
// where g is the reference image's gradient at u (central differences).
//
// Across epipolar lines only (AlignmentState::epipole set): a pose error that
// moves a pixel along its epipolar line is what a wrong depth of the source
// also does, so the source's depth errors would pass into the pose there;
// one that moves it across the line is what breaks matching, and the depth
// cannot explain it. With the epipole e (homogeneous, reference pixels) the
// line through u has unit normal n; the Jacobian takes g's part across the
// line, (g.n) n, and the term weighs c^2 = (g.n)^2 / |g|^2, so that
// motion along the lines stays unobserved (the tracker's).
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

// A source pixel: its point in the source camera frame and its grey level.
struct AlignmentPoint {
  Vec3 point;
  float intensity;
};

// Source -> reference rigid motion and the brightness change.
struct AlignmentState {
  float rotation[9];  // row-major
  Vec3 translation;
  float log_gain, bias;
  bool across_epipolar;  // only the motion across epipolar lines is observed
  Vec3 epipole;          // the source's centre in the reference image, homogeneous (K t)
};

struct AlignmentIntrinsics {
  float fx, fy, cx, cy;
  int width, height;
};

constexpr int kAlignmentParameters = 8;  // v (3), w (3), a, b

struct AlignmentTerm {
  float weight;  // c^2 across epipolar lines, else 1
  float residual;
  float jacobian[kAlignmentParameters];
};

// False when the point falls behind the reference or outside its image
// (with a one-pixel border for the gradient). Sampler: float operator()(x, y)
// bilinear in pixel-centre coordinates of the reference image.
template <typename Sampler>
AMHMVS_HD bool alignmentTerm(const AlignmentPoint& source, const AlignmentState& state,
                             const AlignmentIntrinsics& reference, const Sampler& sample, AlignmentTerm* term) {
  const float* R = state.rotation;
  const Vec3 p = source.point;
  const Vec3 X = make_vec3(R[0] * p.x + R[1] * p.y + R[2] * p.z, R[3] * p.x + R[4] * p.y + R[5] * p.z,
                           R[6] * p.x + R[7] * p.y + R[8] * p.z) +
                 state.translation;
  if (!(X.z > 1e-6f)) return false;
  const float inv_z = 1.0f / X.z;
  const float u = reference.fx * X.x * inv_z + reference.cx;
  const float v = reference.fy * X.y * inv_z + reference.cy;
  if (!(u >= 1.0f && v >= 1.0f && u <= reference.width - 2.0f && v <= reference.height - 2.0f)) return false;
  const float gain = expf(state.log_gain);
  float gx = 0.5f * (sample(u + 1.0f, v) - sample(u - 1.0f, v));
  float gy = 0.5f * (sample(u, v + 1.0f) - sample(u, v - 1.0f));
  term->weight = 1.0f;
  if (state.across_epipolar) {
    // The line through (u, v, 1) and the epipole: (a, b, c) = u x e.
    const Vec3 line = cross(make_vec3(u, v, 1.0f), state.epipole);
    const float norm = sqrtf(line.x * line.x + line.y * line.y);
    const float gradient_squared = gx * gx + gy * gy;
    if (!(norm > 0.0f) || !(gradient_squared > 0.0f)) return false;
    const float nx = line.x / norm, ny = line.y / norm;
    const float across = gx * nx + gy * ny;
    term->weight = across * across / gradient_squared;
    gx = across * nx;
    gy = across * ny;
  }
  term->residual = sample(u, v) - (gain * source.intensity + state.bias);
  const Vec3 dv = make_vec3(gx * reference.fx * inv_z, gy * reference.fy * inv_z,
                            -(gx * reference.fx * X.x + gy * reference.fy * X.y) * inv_z * inv_z);
  const Vec3 dw = cross(X, dv);
  float* J = term->jacobian;
  J[0] = dv.x, J[1] = dv.y, J[2] = dv.z;
  J[3] = dw.x, J[4] = dw.y, J[5] = dw.z;
  J[6] = -gain * source.intensity;
  J[7] = -1.0f;
  return true;
}

// Huber weight of a residual (IRLS): 1 within `k`, k / |r| beyond.
AMHMVS_HD float huberWeight(float residual, float k) {
  const float magnitude = fabsf(residual);
  return magnitude <= k ? 1.0f : k / magnitude;
}

// The Huber cost of a residual: r^2 / 2 within `k`, k (|r| - k / 2) beyond.
AMHMVS_HD float huberCost(float residual, float k) {
  const float magnitude = fabsf(residual);
  return magnitude <= k ? 0.5f * residual * residual : k * (magnitude - 0.5f * k);
}

}  // namespace mvs
}  // namespace amhmvs
