#include "amhmvs_mapping/mvs/plane_map.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {
namespace {

Vec3 cameraRay(const PinholeCamera& camera, double x, double y) {
  return {static_cast<float>((x - camera.cx) / camera.fx), static_cast<float>((y - camera.cy) / camera.fy), 1.0f};
}

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
  const double sx = static_cast<double>(from_camera.width) / to_width;
  const double sy = static_cast<double>(from_camera.height) / to_height;
  const float intensity_factor = -0.5f / (sigma_intensity * sigma_intensity);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < to_height; ++y) {
    for (int x = 0; x < to_width; ++x) {
      const Vec3 to_ray = cameraRay(to_camera, x, y);
      const double u = (x + 0.5) * sx - 0.5, v = (y + 0.5) * sy - 0.5;  // in the `from` image
      const int cu = static_cast<int>(std::lround(u)), cv = static_cast<int>(std::lround(v));
      const float guide = to_image.at(x, y);
      // The neighbours' planes on this pixel's ray and their log weights.
      float depths[9], log_weights[9], max_log_weight = -INFINITY;
      Vec3 normals[9];
      int count = 0;
      for (int qy = cv - 1; qy <= cv + 1; ++qy) {
        for (int qx = cu - 1; qx <= cu + 1; ++qx) {
          if (qx < 0 || qy < 0 || qx >= from_camera.width || qy >= from_camera.height) continue;
          const float depth = from_depth.at(qx, qy);
          const Vec3 n = {from_normal.at(qx, qy, 0), from_normal.at(qx, qy, 1), from_normal.at(qx, qy, 2)};
          if (!(depth > 0.0f) || !(dot(n, n) > 0.5f)) continue;
          // The `from` pixel's plane (camera frame: the same at every scale)
          // on the fine pixel's ray.
          const Plane plane = planeFromDepthNormal(n, depth, cameraRay(from_camera, qx, qy));
          const float to_depth = planeDepth(plane, to_ray);
          if (!(to_depth > 0.0f) || !std::isfinite(to_depth)) continue;
          const float dx = static_cast<float>(qx - u), dy = static_cast<float>(qy - v);
          const float di = guide - static_cast<float>(from_image.at(qx, qy));
          depths[count] = to_depth;
          normals[count] = n;
          log_weights[count] = -0.5f * (dx * dx + dy * dy) + intensity_factor * di * di;
          max_log_weight = std::max(max_log_weight, log_weights[count]);
          ++count;
        }
      }
      // Weights relative to the largest: no underflow where every neighbour
      // differs much from the guide.
      float weight_sum = 0.0f, depth_sum = 0.0f;
      Vec3 normal_sum = {0.0f, 0.0f, 0.0f};
      for (int k = 0; k < count; ++k) {
        const float w = std::exp(log_weights[k] - max_log_weight);
        weight_sum += w;
        depth_sum += w * depths[k];
        normal_sum = normal_sum + w * normals[k];
      }
      if (!(weight_sum > 0.0f) || !(dot(normal_sum, normal_sum) > 0.0f)) continue;
      out.depth.at(x, y) = depth_sum / weight_sum;
      setNormal(&out.normal, x, y, normalized(normal_sum));
    }
  }
  return out;
}

PlaneMap reprojectPlanes(const std::vector<PlaneMapView>& from, const PinholeCamera& to, float max_cost,
                         int splat_radius) {
  PlaneMap out{ImageF(to.width, to.height, 1, std::nanf("")), ImageF(to.width, to.height, 3, 0.0f)};
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
            const float splat_depth = planeDepth(plane, cameraRay(to, qx, qy));
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
