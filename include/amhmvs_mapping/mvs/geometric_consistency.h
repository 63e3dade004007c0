// Geometric consistency with the source views' depth maps (not in the paper;
// the second pass of the public implementation's successors, ACMM/ACMP):
//
//   cost_j(h) = m_j(h) + lambda * min(e_j(h), tau)
//
// where m_j is the photometric cost (eq. 15) and e_j the forward-backward
// reprojection error of the reference pixel p: the point of hypothesis h at p
// is projected into source j, takes that source's depth there (nearest
// pixel), goes back into the reference image, and lands at p'; e_j = |p - p'|
// in pixels. A source without depth there costs the full tau.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

namespace amhmvs {
namespace mvs {

// Source j's way back into the reference image: p' ~ A^-1 (d_s q - b) for a
// source pixel q with depth d_s (A, b: SourceGeometry), and where its depth
// map lies in the concatenated source depths.
struct SourceBackprojection {
  Mat3 A_inv;
  long long depth_offset;  // first pixel of source j's depth map; -1: none
};

struct GeometricTerm {
  bool enabled;
  float weight;     // lambda
  float max_error;  // tau, pixels
};

// min(e_j, tau) for the plane at reference pixel (x, y) (ray: its pixel ray).
AMHMVS_HD float reprojectionError(const GeometricTerm& term, const SourceGeometry& g,
                                  const SourceBackprojection& back, const float* source_depths,
                                  const Plane& plane, Vec3 ray, int x, int y) {
  const float depth = planeDepth(plane, ray);
  if (back.depth_offset < 0 || !(depth > 0.0f)) return term.max_error;
  const Vec3 p = {static_cast<float>(x), static_cast<float>(y), 1.0f};
  const Vec3 ap = mul(g.A, p);
  const Vec3 q = {depth * ap.x + g.b.x, depth * ap.y + g.b.y, depth * ap.z + g.b.z};
  if (!(q.z > 0.0f)) return term.max_error;
  const float u = q.x / q.z, v = q.y / q.z;
  const int iu = static_cast<int>(floorf(u + 0.5f)), iv = static_cast<int>(floorf(v + 0.5f));
  const int width = static_cast<int>(g.width), height = static_cast<int>(g.height);
  if (!(u > -0.5f && v > -0.5f) || iu < 0 || iv < 0 || iu >= width || iv >= height) return term.max_error;
  const float source_depth = source_depths[back.depth_offset + static_cast<long long>(iv) * width + iu];
  if (!(source_depth > 0.0f)) return term.max_error;  // NaN or none
  const Vec3 back_point = mul(back.A_inv, {source_depth * u - g.b.x, source_depth * v - g.b.y,
                                           source_depth - g.b.z});
  if (!(back_point.z > 0.0f)) return term.max_error;
  const float dx = back_point.x / back_point.z - p.x, dy = back_point.y / back_point.z - p.y;
  const float error = sqrtf(dx * dx + dy * dy);
  return error < term.max_error ? error : term.max_error;  // NaN: tau
}

}  // namespace mvs
}  // namespace amhmvs
