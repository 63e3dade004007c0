// One pixel of resamplePlanes (plane_map.h): the planes of a view at one
// scale carried to one pixel of another scale of the same view, by joint
// bilateral upsampling guided by the finer image. Written once for the CPU
// loop (plane_map.cpp) and the CUDA kernel (cuda_backend.cu), which carries a
// coarse-to-fine estimate's planes on the device.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace mvs {

// Pinhole intrinsics in double, as the host's camera model keeps them (rays
// are computed in double and rounded, on both backends).
struct RayCamera {
  double fx, fy, cx, cy;
  int width, height;
};

AMHMVS_HD Vec3 cameraRay(const RayCamera& camera, double x, double y) {
  return {static_cast<float>((x - camera.cx) / camera.fx), static_cast<float>((y - camera.cy) / camera.fy), 1.0f};
}

// What resamplePixel reads: `from`'s depth (1 channel), normals (3) and grey
// image, and `to`'s grey image, all row-major at their camera's size.
struct PlaneResampling {
  RayCamera from, to;
  const float* from_depth;
  const float* from_normal;
  const uint8_t* from_image;
  const uint8_t* to_image;
  float intensity_factor;  // -1 / (2 sigma_intensity^2)
};

// Pixel (x, y) of `to`: the planes of the 3x3 `from` pixels around it,
// evaluated on its ray, averaged with the weights
//   w = exp(-(dx^2 + dy^2) / 2) * exp(-(I_to - I_from)^2 / (2 sigma^2))
// (dx, dy in `from` pixels; relative to the largest, so that they never all
// underflow). False (nothing written) where none of them has a valid plane.
AMHMVS_HD bool resamplePixel(const PlaneResampling& r, int x, int y, float* depth_out, Vec3* normal_out) {
  const RayCamera& from = r.from;
  const Vec3 to_ray = cameraRay(r.to, x, y);
  const double sx = static_cast<double>(from.width) / r.to.width;
  const double sy = static_cast<double>(from.height) / r.to.height;
  const double u = (x + 0.5) * sx - 0.5, v = (y + 0.5) * sy - 0.5;  // in the `from` image
  const int cu = static_cast<int>(lround(u)), cv = static_cast<int>(lround(v));
  const float guide = r.to_image[y * r.to.width + x];
  float depths[9], log_weights[9], max_log_weight = -INFINITY;
  Vec3 normals[9];
  int count = 0;
  for (int qy = cv - 1; qy <= cv + 1; ++qy) {
    for (int qx = cu - 1; qx <= cu + 1; ++qx) {
      if (qx < 0 || qy < 0 || qx >= from.width || qy >= from.height) continue;
      const int q = qy * from.width + qx;
      const float depth = r.from_depth[q];
      const Vec3 n = {r.from_normal[3 * q], r.from_normal[3 * q + 1], r.from_normal[3 * q + 2]};
      if (!(depth > 0.0f) || !(dot(n, n) > 0.5f)) continue;
      // The `from` pixel's plane (camera frame: the same at every scale) on
      // this pixel's ray.
      const Plane plane = planeFromDepthNormal(n, depth, cameraRay(from, qx, qy));
      const float to_depth = planeDepth(plane, to_ray);
      if (!(to_depth > 0.0f) || !isfinite_hd(to_depth)) continue;
      const float dx = static_cast<float>(qx - u), dy = static_cast<float>(qy - v);
      const float di = guide - static_cast<float>(r.from_image[q]);
      depths[count] = to_depth;
      normals[count] = n;
      log_weights[count] = -0.5f * (dx * dx + dy * dy) + r.intensity_factor * di * di;
      max_log_weight = fmaxf(max_log_weight, log_weights[count]);
      ++count;
    }
  }
  float weight_sum = 0.0f, depth_sum = 0.0f;
  Vec3 normal_sum = {0.0f, 0.0f, 0.0f};
  for (int k = 0; k < count; ++k) {
    const float w = expf(log_weights[k] - max_log_weight);
    weight_sum += w;
    depth_sum += w * depths[k];
    normal_sum = normal_sum + w * normals[k];
  }
  if (!(weight_sum > 0.0f) || !(dot(normal_sum, normal_sum) > 0.0f)) return false;
  *depth_out = depth_sum / weight_sum;
  *normal_out = normalized(normal_sum);
  return true;
}

}  // namespace mvs
}  // namespace amhmvs
