// The per-pixel code's view of two cameras (host side): the reference's
// intrinsics and a source's geometry relative to it (matching_cost.h).
#pragma once

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

namespace amhmvs {
namespace mvs {

Intrinsics intrinsicsOf(const PinholeCamera& camera);

// A = K_s R K_r^-1 and b = K_s t of `source` relative to `reference`, with
// the source's size; `layer` is the sampler's index of its image. `A_double`
// (optional): A before the rounding to float (the estimator inverts it).
SourceGeometry sourceGeometry(const PinholeCamera& reference, const PinholeCamera& source, int layer,
                              Eigen::Matrix3d* A_double = nullptr);

}  // namespace mvs
}  // namespace amhmvs
