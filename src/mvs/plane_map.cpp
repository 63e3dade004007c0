#include "amhmvs_mapping/mvs/plane_map.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {
namespace {

void setNormal(ImageF* normal, int x, int y, Vec3 n) {
  normal->at(x, y, 0) = n.x;
  normal->at(x, y, 1) = n.y;
  normal->at(x, y, 2) = n.z;
}

void checkSize(const PlaneMapView& view, size_t index) {
  const PinholeCamera& c = view.camera;
  const bool cost_ok = view.cost.empty() || (view.cost.channels == 1 && view.cost.sameSize(c.width, c.height));
  if (view.depth.channels != 1 || view.normal.channels != 3 || !view.depth.sameSize(c.width, c.height) ||
      !view.normal.sameSize(c.width, c.height) || !cost_ok) {
    throw InputError("reprojectPlanes: plane map " + std::to_string(index) + " is not 1 (depth, cost) and 3 (normal) "
                     "channels at its camera's size " + std::to_string(c.width) + "x" + std::to_string(c.height));
  }
}

}  // namespace

PlaneMap resamplePlanes(const ImageViewF& from_depth, const ImageViewF& from_normal,
                        const PinholeCamera& from_camera, const ImageViewU8& from_image,
                        const PinholeCamera& to_camera, const ImageViewU8& to_image, float sigma_intensity) {
  const int to_width = to_camera.width, to_height = to_camera.height;
  PlaneMap out{ImageF(to_width, to_height, 1, std::nanf("")), ImageF(to_width, to_height, 3, 0.0f)};
  const PlaneResampling resampling{rayCamera(from_camera), rayCamera(to_camera), from_depth.data, from_normal.data,
                                   from_image.data, to_image.data, -0.5f / (sigma_intensity * sigma_intensity)};
#pragma omp parallel for schedule(static)
  for (int y = 0; y < to_height; ++y) {
    for (int x = 0; x < to_width; ++x) {
      Vec3 normal;
      if (resamplePixel(resampling, x, y, &out.depth.at(x, y), &normal)) setNormal(&out.normal, x, y, normal);
    }
  }
  return out;
}

PlaneMap reprojectPlanes(const std::vector<PlaneMapView>& from, const PinholeCamera& to, float max_cost,
                         int splat_radius) {
  PlaneMap out{ImageF(to.width, to.height, 1, std::nanf("")), ImageF(to.width, to.height, 3, 0.0f)};
  const RayCamera to_rays = rayCamera(to);
  for (size_t v = 0; v < from.size(); ++v) {
    const PlaneMapView& view = from[v];
    checkSize(view, v);
    const RelativePose rel = relativePose(view.camera, to);  // X_to = R X_view + t
    const Eigen::Matrix3f R = rel.R.cast<float>();
    const Eigen::Vector3f t = rel.t.cast<float>();
    for (int y = 0; y < view.camera.height; ++y) {
      for (int x = 0; x < view.camera.width; ++x) {
        const float depth = view.depth.at(x, y);
        if (!(depth > 0.0f) || !std::isfinite(depth)) continue;
        if (!view.cost.empty() && !(view.cost.at(x, y) <= max_cost)) continue;
        const Eigen::Vector3f n_view(view.normal.at(x, y, 0), view.normal.at(x, y, 1), view.normal.at(x, y, 2));
        if (!(n_view.squaredNorm() > 0.5f)) continue;
        const Eigen::Vector3f point = R * view.camera.backproject(x, y, depth).cast<float>() + t;
        const Eigen::Vector3f n_to = R * n_view;
        const Vec3 n = {n_to.x(), n_to.y(), n_to.z()};
        const Vec3 p = {point.x(), point.y(), point.z()};
        if (!(p.z > 0.0f) || !(dot(n, p) < 0.0f)) continue;  // behind `to`, or seen from the back
        const Plane plane = {n, -dot(n, p)};
        const Eigen::Vector2d pixel = to.project(point.cast<double>());
        const int cu = static_cast<int>(std::lround(pixel.x())), cv = static_cast<int>(std::lround(pixel.y()));
        for (int qy = cv - splat_radius; qy <= cv + splat_radius; ++qy) {
          for (int qx = cu - splat_radius; qx <= cu + splat_radius; ++qx) {
            if (qx < 0 || qy < 0 || qx >= to.width || qy >= to.height) continue;
            const float splat_depth = planeDepth(plane, cameraRay(to_rays, qx, qy));
            if (!(std::fabs(splat_depth - p.z) <= kMaxSplatDepthSpread * p.z)) continue;
            float& nearest = out.depth.at(qx, qy);
            if (nearest <= splat_depth) continue;  // NaN compares false: written
            nearest = splat_depth;
            setNormal(&out.normal, qx, qy, n);
          }
        }
      }
    }
  }
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
