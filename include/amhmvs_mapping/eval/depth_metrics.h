// Accuracy of depth maps against ground truth: dense ground-truth depth
// (Middlebury) and triangulated sparse points (Strecha fountain).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/core/texture.h"

namespace amhmvs {

// Counts of samples whose relative depth error |d - d_gt| / d_gt is below each
// threshold. A sample with no estimate (NaN) counts as wrong.
struct AccuracyCounts {
  std::vector<double> thresholds;
  std::vector<long> within;
  long total = 0;

  explicit AccuracyCounts(std::vector<double> t = {0.01, 0.02, 0.05})
      : thresholds(std::move(t)), within(thresholds.size(), 0) {}
  void add(double estimate, double truth);
  void merge(const AccuracyCounts& other);
  double fraction(size_t i) const { return total ? static_cast<double>(within[i]) / total : 0.0; }
  // "75.43 / 82.81 / 87.70" (percent)
  std::string percentages() const;
};

// Pixels where `truth` is finite and positive and `valid_mask` (if given) is
// non-zero.
AccuracyCounts denseDepthAccuracy(const ImageF& depth, const ImageF& truth,
                                  const ImageU8* valid_mask);

// An estimated depth map against dense ground truth, split into accuracy
// (relative error of the pixels that have both, within 1/2/5/10 %) and
// completeness (share of the ground-truth pixels that have an estimate).
struct DepthComparison {
  AccuracyCounts accuracy{{0.01, 0.02, 0.05, 0.10}};  // total = pixels with both
  long truth_pixels = 0;

  double completeness() const { return truth_pixels ? static_cast<double>(accuracy.total) / truth_pixels : 0.0; }
  void merge(const DepthComparison& other) {
    accuracy.merge(other.accuracy);
    truth_pixels += other.truth_pixels;
  }
};
// Throws InputError when the sizes differ. With `mask`, only the pixels
// where it is non-zero count.
DepthComparison compareDepth(const ImageF& estimate, const ImageF& truth, const ImageU8* mask = nullptr);

// (The weakly textured pixels that reports split off: core/texture.h.)

struct MiddleburyGroundTruth {
  ImageF depth;        // metres, NaN where unknown
  ImageU8 nonoccluded; // 255 = not occluded
};
// Reads disp0GT.pfm, calib.txt and mask0nocc.* of a Middlebury 2014 scene
// folder. Depth = baseline * f / (disparity + doffs), in metres.
MiddleburyGroundTruth readMiddleburyGroundTruth(const std::string& dir);

struct SparsePoint {
  Eigen::Vector3d position;  // world
  std::vector<int> views;    // ids of the views that observe it
};
// "X Y Z N id_1 ... id_N" per line, '#' comments.
std::vector<SparsePoint> readSparsePoints(const std::string& path);

// Observations of `points` by view `view_id`: depth map value at the nearest
// pixel of the point's projection against the point's z-depth.
AccuracyCounts sparsePointAccuracy(const ImageF& depth, const PinholeCamera& camera, int view_id,
                                   const std::vector<SparsePoint>& points);

}  // namespace amhmvs
