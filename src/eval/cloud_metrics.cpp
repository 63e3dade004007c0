#include "amhmvs_mapping/eval/cloud_metrics.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr size_t kLeafPoints = 8;

}  // namespace

NearestPointIndex::NearestPointIndex(const std::vector<Eigen::Vector3f>& points)
    : points_(points), axis_(points.size(), 0) {
  for (size_t i = 0; i < points_.size(); ++i) {
    if (!points_[i].allFinite()) {
      throw InputError("nearest-point index: point " + std::to_string(i) + " is not finite");
    }
  }
  build(0, points_.size());
}

void NearestPointIndex::build(size_t begin, size_t end) {
  if (end - begin <= kLeafPoints) return;
  Eigen::Vector3f low = points_[begin], high = points_[begin];
  for (size_t i = begin + 1; i < end; ++i) {
    low = low.cwiseMin(points_[i]);
    high = high.cwiseMax(points_[i]);
  }
  Eigen::Index axis;
  (high - low).maxCoeff(&axis);
  const size_t middle = begin + (end - begin) / 2;
  std::nth_element(points_.begin() + begin, points_.begin() + middle, points_.begin() + end,
                   [axis](const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return a[axis] < b[axis]; });
  axis_[middle] = static_cast<unsigned char>(axis);
  build(begin, middle);
  build(middle + 1, end);
}

void NearestPointIndex::search(const Eigen::Vector3f& query, size_t begin, size_t end, double* best_squared) const {
  if (end - begin <= kLeafPoints) {
    for (size_t i = begin; i < end; ++i)
      *best_squared = std::min(*best_squared, (points_[i] - query).cast<double>().squaredNorm());
    return;
  }
  const size_t middle = begin + (end - begin) / 2;
  *best_squared = std::min(*best_squared, (points_[middle] - query).cast<double>().squaredNorm());
  const int axis = axis_[middle];
  // Points before the median lie at or below it on the axis, those after at or above.
  const double offset = static_cast<double>(query[axis]) - points_[middle][axis];
  const bool below = offset < 0;
  search(query, below ? begin : middle + 1, below ? middle : end, best_squared);
  if (offset * offset <= *best_squared) search(query, below ? middle + 1 : begin, below ? end : middle, best_squared);
}

double NearestPointIndex::nearestDistance(const Eigen::Vector3f& query, double max_radius) const {
  if (points_.empty() || !query.allFinite() || !(max_radius >= 0)) return kInfinity;
  double best_squared = max_radius * max_radius;
  // A point exactly at max_radius counts: search a hair beyond, then check.
  double searched = std::nextafter(best_squared, kInfinity);
  search(query, 0, points_.size(), &searched);
  return searched <= best_squared ? std::sqrt(searched) : kInfinity;
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
                                 const NearestPointIndex& index,
                                 const std::vector<double>& thresholds) {
  const double max_threshold = *std::max_element(thresholds.begin(), thresholds.end());
  std::vector<long> within(thresholds.size(), 0);
  const long n = static_cast<long>(queries.size());
#pragma omp parallel
  {
    std::vector<long> local(thresholds.size(), 0);
#pragma omp for schedule(static)
    for (long i = 0; i < n; ++i) {
      const double d = index.nearestDistance(queries[i], max_threshold);
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
  const NearestPointIndex gt_index(ground_truth);
  const NearestPointIndex reconstruction_index(reconstruction);

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
