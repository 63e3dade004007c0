// Point-cloud accuracy and completeness (ETH3D-style definitions), a k-d
// tree for nearest-point queries within a radius, and clouds from depth
// maps.
//
// Definitions, for a distance threshold t:
//   accuracy     = share of reconstructed points with a ground-truth point
//                  within t (Euclidean);
//   completeness = share of ground-truth points with a reconstructed point
//                  within t;
//   F1           = 2 a c / (a + c) (0 when both are 0).
// Unlike the ETH3D evaluation program this does not voxel-downsample the
// clouds or ignore unobserved space: give a ground truth of even density that
// covers only what the cameras can see (e.g. back-projected depth maps).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// Nearest-point queries within a radius: a balanced k-d tree over a copy of
// the points (each split at the median of the box's longest side, leaves of
// up to 8 points). A query visits only the nodes that can hold a point nearer
// than the best found so far, so a dense cloud (a surface seen by hundreds of
// keyframes) costs about as much as a sparse one.
class NearestPointIndex {
 public:
  // Throws InputError for a non-finite point.
  explicit NearestPointIndex(const std::vector<Eigen::Vector3f>& points);

  // Distance to the nearest indexed point if it is at most max_radius,
  // otherwise +infinity (also for an empty index).
  double nearestDistance(const Eigen::Vector3f& query, double max_radius) const;

  size_t size() const { return points_.size(); }

 private:
  void build(size_t begin, size_t end);
  void search(const Eigen::Vector3f& query, size_t begin, size_t end, double* best_squared) const;

  std::vector<Eigen::Vector3f> points_;  // reordered: each range's median splits it
  std::vector<unsigned char> axis_;      // split axis of the range whose median is this index
};

struct CloudMetrics {
  std::vector<double> thresholds;
  std::vector<double> accuracy, completeness, f1;  // fractions in [0, 1]
  size_t reconstruction_points = 0, ground_truth_points = 0;
  // A plain-text table, one row per threshold, percentages.
  std::string table() const;
};

// Throws InputError for an empty or non-positive / non-finite threshold list
// and non-finite points. An empty cloud gives zeros for the fractions.
CloudMetrics evaluateCloud(const std::vector<Eigen::Vector3f>& reconstruction,
                           const std::vector<Eigen::Vector3f>& ground_truth,
                           const std::vector<double>& thresholds);

// A depth map with its camera, which may be at another resolution than the
// depth map (it is then rescaled with PinholeCamera::resized).
struct DepthMapView {
  PinholeCamera camera;
  ImageF depth;  // z-depth; NaN/inf/<= 0 = none
};

// World points of every `stride`-th pixel in x and y of each depth map.
// Throws InputError for stride < 1, an invalid camera, a multi-channel depth
// map, or a depth map whose aspect ratio differs from its camera's.
std::vector<Eigen::Vector3f> backprojectDepthMaps(const std::vector<DepthMapView>& views,
                                                  int stride);

// Z-buffer depth map of world points seen by `camera`: each point in front of
// the camera writes its depth to the (2 * splat_radius + 1)^2 pixels around
// its projection's nearest pixel, the nearest depth winning; NaN elsewhere.
// Lets depth-map metrics (e.g. sparsePointAccuracy) judge a cloud.
ImageF renderPointDepth(const std::vector<Eigen::Vector3f>& world_points,
                        const PinholeCamera& camera, int splat_radius);

}  // namespace amhmvs
