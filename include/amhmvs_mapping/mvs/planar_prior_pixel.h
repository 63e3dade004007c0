// The planar prior's term in a hypothesis's cost (not in the paper; in the
// manner of ACMP, Xu & Tao 2020), written once for both backends. A first
// estimate's confident pixels are triangulated in the image and each
// triangle's plane becomes the prior of the pixels it covers
// (planar_prior.h). A hypothesis of depth d and normal n at a pixel whose
// prior plane gives depth d_p and normal n_p costs, on top of its matching
// cost,
//
//   lambda * (1 - exp(-(e_d^2 + e_n^2) / 2)),
//   e_d = (d - d_p) / (sigma_d d_p),   e_n^2 = 2 (1 - n . n_p) / sigma_n^2
//
// (e_n is the angle between the normals in units of sigma_n, to second
// order). The term is bounded by lambda: where the matching cost has a clear
// minimum (texture) that minimum stays; where it is flat (a white wall) the
// prior decides.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

struct PlanarPriorTerm {
  const float* depth = nullptr;   // per pixel; NaN or <= 0: no prior there (null: off)
  const float* normal = nullptr;  // 3 per pixel, unit, camera frame
  float weight = 0;               // lambda
  float inv_depth_sigma = 0;      // 1 / sigma_d (relative depth)
  float inv_normal_sigma_squared = 0;  // 1 / sigma_n^2 (radians)
};

// The prior's plane at pixel `index` (its depth on the pixel's ray and its
// normal), or false where there is none.
AMHMVS_HD bool planarPriorAt(const PlanarPriorTerm& prior, int index, float* depth, Vec3* normal) {
  if (!prior.depth || !(prior.depth[index] > 0.0f)) return false;
  *depth = prior.depth[index];
  *normal = {prior.normal[3 * index], prior.normal[3 * index + 1], prior.normal[3 * index + 2]};
  return true;
}

// 0 where there is no prior (and when it is off: the paper's costs exactly).
AMHMVS_HD float planarPriorCost(const PlanarPriorTerm& prior, int index, float depth, Vec3 normal) {
  float prior_depth;
  Vec3 prior_normal;
  if (!planarPriorAt(prior, index, &prior_depth, &prior_normal)) return 0.0f;
  const float e_d = (depth - prior_depth) / prior_depth * prior.inv_depth_sigma;
  const float e_n_squared = 2.0f * (1.0f - dot(normal, prior_normal)) * prior.inv_normal_sigma_squared;
  return prior.weight * (1.0f - expf(-0.5f * (e_d * e_d + e_n_squared)));
}

}  // namespace mvs
}  // namespace amhmvs
