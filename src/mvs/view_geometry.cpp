#include "amhmvs_mapping/mvs/view_geometry.h"

namespace amhmvs {
namespace mvs {

Intrinsics intrinsicsOf(const PinholeCamera& camera) {
  return {static_cast<float>(camera.fx), static_cast<float>(camera.fy), static_cast<float>(camera.cx),
          static_cast<float>(camera.cy)};
}

SourceGeometry sourceGeometry(const PinholeCamera& reference, const PinholeCamera& source, int layer,
                              Eigen::Matrix3d* A_double) {
  const RelativePose relative = relativePose(reference, source);
  const Eigen::Matrix3d A = source.K() * relative.R * reference.K().inverse();
  const Eigen::Vector3d b = source.K() * relative.t;
  SourceGeometry g;
  for (int i = 0; i < 9; ++i) g.A.m[i] = static_cast<float>(A(i / 3, i % 3));
  g.b = {static_cast<float>(b.x()), static_cast<float>(b.y()), static_cast<float>(b.z())};
  g.width = static_cast<float>(source.width);
  g.height = static_cast<float>(source.height);
  g.layer = layer;
  if (A_double) *A_double = A;
  return g;
}

}  // namespace mvs
}  // namespace amhmvs
