// Point-cloud accuracy and completeness (ETH3D-style definitions), a voxel
// grid for fixed-radius nearest-neighbour queries, and clouds from depth
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

// A cell size for counting within `thresholds`: half the largest, so that
// the search within the smallest visits few cells.
double bandCellSize(const std::vector<double>& thresholds);

// Points bucketed in cubic cells of a fixed size: finds the nearest point
// within a radius by visiting only the cells the radius reaches. Cells are
// kept sorted by their integer coordinates (no hash, no extent limit).
class VoxelGridIndex {
 public:
  // Throws InputError for a non-positive or non-finite cell size, or a
  // non-finite point.
  VoxelGridIndex(const std::vector<Eigen::Vector3f>& points, double cell_size);

  // Distance to the nearest indexed point if it is at most max_radius,
  // otherwise +infinity (also for an empty index). With enough_radius > 0 the
  // search stops at the first point within it and returns that point's
  // distance (at most enough_radius, not always the least): counting the
  // points within thresholds needs no more, and a query amid a dense clump
  // then costs one hit instead of the clump.
  double nearestDistance(const Eigen::Vector3f& query, double max_radius, double enough_radius = 0) const;
  // For counting points within thresholds (ascending): a distance in the
  // same band of them as the nearest point's, +infinity beyond the last.
  // Searches each threshold's radius in turn, stopping at the first point
  // within it, so that a query amid a dense cloud costs a few hits.
  double distanceInBand(const Eigen::Vector3f& query, const std::vector<double>& thresholds) const;

  size_t size() const { return points_.size(); }

 private:
  struct Entry {
    int x, y, z;
    unsigned index;
  };
  void cellOf(const Eigen::Vector3f& p, int* x, int* y, int* z) const;

  std::vector<Eigen::Vector3f> points_;  // in cell order
  std::vector<Entry> cells_;             // sorted by (x, y, z)
  double cell_size_;
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
