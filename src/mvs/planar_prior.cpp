#include "amhmvs_mapping/mvs/planar_prior.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/texture.h"
#include "amhmvs_mapping/mvs/delaunay.h"

namespace amhmvs {
namespace mvs {
namespace {

struct SupportPoint {
  Eigen::Vector3d point;   // camera frame
  Eigen::Vector3d normal;  // unit
};

}  // namespace

PlaneMap planarPrior(const ImageViewU8& image, const ImageViewF& depth, const ImageViewF& normal,
                     const ImageViewF& cost, const PinholeCamera& camera, const PatchMatchOptions& options,
                     PlanarPriorStats* stats) {
  const int width = camera.width, height = camera.height;
  if (!image.sameSize(width, height) || image.channels != 1 || !depth.sameSize(width, height) ||
      depth.channels != 1 || !normal.sameSize(width, height) || normal.channels != 3 ||
      !cost.sameSize(width, height) || cost.channels != 1)
    throw InputError("planar prior: image, depth, normal and cost maps must be 1, 1, 3 and 1 channels at " +
                     std::to_string(width) + "x" + std::to_string(height));
  const ImageU8 weak = weakTextureMask(image, options.planar_prior_max_gradient);
  PlanarPriorStats local;
  PlaneMap out;
  out.depth = ImageF(width, height, 1);
  out.normal = ImageF(width, height, 3);
  std::fill(out.depth.data.begin(), out.depth.data.end(), std::numeric_limits<float>::quiet_NaN());

  // The support points: per cell, its confident pixel of lowest cost.
  const int cell = options.planar_prior_cell;
  std::vector<Point2i> pixels;
  std::vector<SupportPoint> support;
  for (int cy = 0; cy < height; cy += cell) {
    for (int cx = 0; cx < width; cx += cell) {
      int best_x = -1, best_y = -1;
      float best_cost = options.planar_prior_max_cost;
      for (int y = cy; y < std::min(cy + cell, height); ++y) {
        for (int x = cx; x < std::min(cx + cell, width); ++x) {
          const float z = depth.at(x, y), c = cost.at(x, y);
          if (z > 0 && std::isfinite(z) && c <= best_cost) best_x = x, best_y = y, best_cost = c;
        }
      }
      if (best_x < 0) continue;
      const Eigen::Vector3d n(normal.at(best_x, best_y, 0), normal.at(best_x, best_y, 1), normal.at(best_x, best_y, 2));
      if (!n.allFinite() || n.norm() < 0.5) continue;
      pixels.push_back({best_x, best_y});
      support.push_back({camera.backproject(best_x, best_y, depth.at(best_x, best_y)), n.normalized()});
    }
  }
  local.support_points = static_cast<int>(support.size());

  const std::vector<std::array<int, 3>> triangles = delaunayTriangles(pixels);
  local.triangles = static_cast<int>(triangles.size());
  const double min_corner_cos = std::cos(options.planar_prior_max_vertex_angle_deg * M_PI / 180.0);
  const double min_view_cos = std::cos(options.max_normal_angle_deg * M_PI / 180.0);
  for (const auto& triangle : triangles) {
    const Eigen::Vector3d& a = support[triangle[0]].point;
    const Eigen::Vector3d& b = support[triangle[1]].point;
    const Eigen::Vector3d& c = support[triangle[2]].point;
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (!(n.norm() > 0)) continue;
    n.normalize();
    const Eigen::Vector3d centroid = (a + b + c) / 3.0;
    if (n.dot(centroid) > 0) n = -n;  // facing the camera
    if (-n.dot(centroid.normalized()) < min_view_cos) continue;  // seen at a grazing angle
    bool agrees = true;
    for (int k : triangle) agrees = agrees && n.dot(support[k].normal) >= min_corner_cos;
    if (!agrees) continue;
    ++local.used_triangles;
    const double offset = -n.dot(a);  // n . X + offset = 0
    const Point2i& p0 = pixels[triangle[0]];
    const Point2i& p1 = pixels[triangle[1]];
    const Point2i& p2 = pixels[triangle[2]];
    const int x_lo = std::min({p0.x, p1.x, p2.x}), x_hi = std::max({p0.x, p1.x, p2.x});
    const int y_lo = std::min({p0.y, p1.y, p2.y}), y_hi = std::max({p0.y, p1.y, p2.y});
    const auto edge = [](const Point2i& u, const Point2i& v, int x, int y) {
      return static_cast<long>(v.x - u.x) * (y - u.y) - static_cast<long>(v.y - u.y) * (x - u.x);
    };
    for (int y = y_lo; y <= y_hi; ++y) {
      for (int x = x_lo; x <= x_hi; ++x) {
        // Inside or on the edges (the triangles are positively oriented).
        if (edge(p0, p1, x, y) < 0 || edge(p1, p2, x, y) < 0 || edge(p2, p0, x, y) < 0) continue;
        if (!weak.at(x, y)) continue;
        const Eigen::Vector3d ray((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
        const double along = n.dot(ray);
        if (!(along < 0)) continue;
        const double z = -offset / along;
        if (!(z > 0) || !std::isfinite(z)) continue;
        if (!(out.depth.at(x, y) > 0)) ++local.covered_pixels;
        out.depth.at(x, y) = static_cast<float>(z);
        for (int k = 0; k < 3; ++k) out.normal.at(x, y, k) = static_cast<float>(n[k]);
      }
    }
  }
  if (stats) *stats = local;
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
