// Scenes with exact depth for the surface map's tests: cameras looking at a
// point, and the z-depth of spheres and planes they see (test_tsdf_map.cpp,
// the comparison with Open3D).
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/mapping/tsdf_map.h"

namespace amhmvs {
namespace test {

// A camera at `centre` looking at `target` (y down in the image, world z up).
inline PinholeCamera lookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target, int width = 160,
                            int height = 120) {
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = 0.8 * width;
  camera.cx = 0.5 * (width - 1);
  camera.cy = 0.5 * (height - 1);
  const Eigen::Vector3d forward = (target - centre).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-6) right = Eigen::Vector3d::UnitX();
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d camera_to_world;
  camera_to_world << right, down, forward;
  camera.R = camera_to_world.transpose();
  camera.t = -camera.R * centre;
  return camera;
}

struct Sphere {
  Eigen::Vector3d centre;
  double radius;
};
// The plane of points p with normal.dot(p) = offset.
struct Plane {
  Eigen::Vector3d normal;
  double offset;
};

// Exact z-depth of the nearest sphere or plane each pixel's ray meets (NaN
// where it meets none).
inline SurfaceDepth sceneDepth(const PinholeCamera& camera, const std::vector<Sphere>& spheres,
                               const std::vector<Plane>& planes = {}) {
  SurfaceDepth depth;
  depth.camera = camera;
  depth.depth = ImageF(camera.width, camera.height, 1, NAN);
  const Eigen::Vector3d eye = camera.center();
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray_camera = camera.backproject(x, y, 1);
      const Eigen::Vector3d ray = (camera.R.transpose() * ray_camera).normalized();
      double nearest = std::numeric_limits<double>::infinity();
      for (const Sphere& sphere : spheres) {
        const double b = ray.dot(eye - sphere.centre);
        const double c = (eye - sphere.centre).squaredNorm() - sphere.radius * sphere.radius;
        const double disc = b * b - c;
        if (disc >= 0 && -b - std::sqrt(disc) > 0) nearest = std::min(nearest, -b - std::sqrt(disc));
      }
      for (const Plane& plane : planes) {
        const double along = plane.normal.dot(ray);
        if (std::abs(along) < 1e-12) continue;
        const double s = (plane.offset - plane.normal.dot(eye)) / along;
        if (s > 0) nearest = std::min(nearest, s);
      }
      if (std::isfinite(nearest)) depth.depth.at(x, y) = static_cast<float>(nearest / ray_camera.norm());
    }
  return depth;
}

inline SurfaceDepth sphereDepth(const PinholeCamera& camera, const Eigen::Vector3d& centre, double radius) {
  return sceneDepth(camera, {Sphere{centre, radius}});
}

}  // namespace test
}  // namespace amhmvs
