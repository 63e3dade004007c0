#include "amhmvs_mapping/eval/cloud_metrics.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <tuple>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Cell coordinates stay well inside int even for far points and tiny cells.
int cellCoordinate(double value, double cell_size) {
  const double c = std::floor(value / cell_size);
  return static_cast<int>(std::clamp(c, -1e9, 1e9));
}

}  // namespace

VoxelGridIndex::VoxelGridIndex(const std::vector<Eigen::Vector3f>& points, double cell_size)
    : cell_size_(cell_size) {
  if (!(std::isfinite(cell_size) && cell_size > 0)) {
    throw InputError("voxel grid: cell size must be positive and finite");
  }
  std::vector<Entry> entries(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw InputError("voxel grid: point " + std::to_string(i) + " is not finite");
    }
    cellOf(points[i], &entries[i].x, &entries[i].y, &entries[i].z);
    entries[i].index = static_cast<unsigned>(i);
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.x, a.y, a.z, a.index) < std::tie(b.x, b.y, b.z, b.index);
  });
  points_.reserve(points.size());
  for (Entry& e : entries) {
    points_.push_back(points[e.index]);
    e.index = static_cast<unsigned>(points_.size() - 1);
  }
  cells_ = std::move(entries);
}

void VoxelGridIndex::cellOf(const Eigen::Vector3f& p, int* x, int* y, int* z) const {
  *x = cellCoordinate(p.x(), cell_size_);
  *y = cellCoordinate(p.y(), cell_size_);
  *z = cellCoordinate(p.z(), cell_size_);
}

double VoxelGridIndex::nearestDistance(const Eigen::Vector3f& query, double max_radius, double enough_radius) const {
  if (cells_.empty() || !query.allFinite() || !(max_radius >= 0)) return kInfinity;
  int qx, qy, qz;
  cellOf(query, &qx, &qy, &qz);
  const int reach = static_cast<int>(std::ceil(max_radius / cell_size_));
  double best_squared = max_radius * max_radius;
  const double enough_squared = enough_radius * enough_radius;
  bool found = false;
  const auto key_less = [](const Entry& e, const std::tuple<int, int, int>& key) {
    return std::tie(e.x, e.y, e.z) < key;
  };
  for (int dx = -reach; dx <= reach; ++dx) {
    for (int dy = -reach; dy <= reach; ++dy) {
      // Cells along z with equal x and y are contiguous: one range per column.
      const std::tuple<int, int, int> first(qx + dx, qy + dy, qz - reach);
      auto it = std::lower_bound(cells_.begin(), cells_.end(), first, key_less);
      for (; it != cells_.end() && it->x == qx + dx && it->y == qy + dy && it->z <= qz + reach;
           ++it) {
        const double d2 = (points_[it->index] - query).cast<double>().squaredNorm();
        if (d2 <= best_squared) {
          best_squared = d2;
          found = true;
          if (d2 <= enough_squared) return std::sqrt(d2);
        }
      }
    }
  }
  return found ? std::sqrt(best_squared) : kInfinity;
}

double VoxelGridIndex::distanceInBand(const Eigen::Vector3f& query, const std::vector<double>& thresholds) const {
  for (double threshold : thresholds) {
    const double distance = nearestDistance(query, threshold, threshold);
    if (std::isfinite(distance)) return distance;
  }
  return kInfinity;
}

double bandCellSize(const std::vector<double>& thresholds) {
  return 0.5 * *std::max_element(thresholds.begin(), thresholds.end());
}

std::string CloudMetrics::table() const {
  std::ostringstream out;
  out << "reconstruction: " << reconstruction_points << " points, ground truth: "
      << ground_truth_points << " points\n";
  out << std::setw(12) << "threshold" << std::setw(12) << "accuracy" << std::setw(14)
      << "completeness" << std::setw(10) << "F1" << "\n";
  out << std::fixed;
  for (size_t i = 0; i < thresholds.size(); ++i) {
    out << std::setw(12) << std::setprecision(4) << thresholds[i] << std::setprecision(2)
        << std::setw(11) << 100 * accuracy[i] << "%" << std::setw(13) << 100 * completeness[i]
        << "%" << std::setw(9) << 100 * f1[i] << "%\n";
  }
  return out.str();
}

namespace {

// For each threshold, the share of `queries` with an indexed point within it.
std::vector<double> sharesWithin(const std::vector<Eigen::Vector3f>& queries,
                                 const VoxelGridIndex& index,
                                 const std::vector<double>& thresholds) {
  std::vector<double> ascending = thresholds;
  std::sort(ascending.begin(), ascending.end());
  std::vector<long> within(thresholds.size(), 0);
  const long n = static_cast<long>(queries.size());
#pragma omp parallel
  {
    std::vector<long> local(thresholds.size(), 0);
#pragma omp for schedule(static)
    for (long i = 0; i < n; ++i) {
      const double d = index.distanceInBand(queries[i], ascending);
      for (size_t k = 0; k < thresholds.size(); ++k) local[k] += d <= thresholds[k];
    }
#pragma omp critical
    for (size_t k = 0; k < thresholds.size(); ++k) within[k] += local[k];
  }
  std::vector<double> shares(thresholds.size(), 0.0);
  for (size_t k = 0; k < thresholds.size(); ++k) {
    shares[k] = n ? static_cast<double>(within[k]) / n : 0.0;
  }
  return shares;
}

}  // namespace

CloudMetrics evaluateCloud(const std::vector<Eigen::Vector3f>& reconstruction,
                           const std::vector<Eigen::Vector3f>& ground_truth,
                           const std::vector<double>& thresholds) {
  if (thresholds.empty()) throw InputError("cloud metrics: no thresholds");
  for (double t : thresholds) {
    if (!(std::isfinite(t) && t > 0)) {
      throw InputError("cloud metrics: thresholds must be positive and finite");
    }
  }
  const VoxelGridIndex gt_index(ground_truth, bandCellSize(thresholds));
  const VoxelGridIndex reconstruction_index(reconstruction, bandCellSize(thresholds));

  CloudMetrics m;
  m.thresholds = thresholds;
  m.reconstruction_points = reconstruction.size();
  m.ground_truth_points = ground_truth.size();
  m.accuracy = sharesWithin(reconstruction, gt_index, thresholds);
  m.completeness = sharesWithin(ground_truth, reconstruction_index, thresholds);
  for (size_t k = 0; k < thresholds.size(); ++k) {
    const double a = m.accuracy[k], c = m.completeness[k];
    m.f1.push_back(a + c > 0 ? 2 * a * c / (a + c) : 0.0);
  }
  return m;
}

std::vector<Eigen::Vector3f> backprojectDepthMaps(const std::vector<DepthMapView>& views,
                                                  int stride) {
  if (stride < 1) throw InputError("back-projection: stride must be >= 1");
  std::vector<Eigen::Vector3f> points;
  for (size_t i = 0; i < views.size(); ++i) {
    const std::string name = "back-projection: depth map " + std::to_string(i);
    const ImageF& depth = views[i].depth;
    if (depth.channels != 1) throw InputError(name + ": must have 1 channel");
    const std::string camera_problem = views[i].camera.validate();
    if (!camera_problem.empty()) throw InputError(name + ": invalid camera: " + camera_problem);
    PinholeCamera camera = views[i].camera;
    if (camera.width != depth.width || camera.height != depth.height) {
      const double aspect_depth = static_cast<double>(depth.width) / depth.height;
      const double aspect_camera = static_cast<double>(camera.width) / camera.height;
      if (std::abs(aspect_depth / aspect_camera - 1) > 0.02) {
        throw InputError(name + ": its aspect ratio differs from its camera's");
      }
      camera = camera.resized(depth.width, depth.height);
    }
    const Eigen::Matrix3d Rt = camera.R.transpose();
    for (int y = 0; y < depth.height; y += stride) {
      for (int x = 0; x < depth.width; x += stride) {
        const float d = depth.at(x, y);
        if (!(std::isfinite(d) && d > 0)) continue;
        const Eigen::Vector3d world = Rt * (camera.backproject(x, y, d) - camera.t);
        if (world.allFinite()) points.push_back(world.cast<float>());
      }
    }
  }
  return points;
}

ImageF renderPointDepth(const std::vector<Eigen::Vector3f>& world_points,
                        const PinholeCamera& camera, int splat_radius) {
  ImageF depth(camera.width, camera.height, 1, std::numeric_limits<float>::quiet_NaN());
  for (const Eigen::Vector3f& p : world_points) {
    const Eigen::Vector3d c = camera.toCamera(p.cast<double>());
    if (!(c.z() > 0)) continue;
    const Eigen::Vector2d uv = camera.project(c);
    if (!uv.allFinite() || !camera.contains(uv)) continue;
    const int u = static_cast<int>(std::floor(uv.x() + 0.5));
    const int v = static_cast<int>(std::floor(uv.y() + 0.5));
    for (int y = std::max(0, v - splat_radius); y <= std::min(camera.height - 1, v + splat_radius);
         ++y) {
      for (int x = std::max(0, u - splat_radius);
           x <= std::min(camera.width - 1, u + splat_radius); ++x) {
        float& d = depth.at(x, y);
        if (!(d <= c.z())) d = static_cast<float>(c.z());
      }
    }
  }
  return depth;
}

}  // namespace amhmvs
