// Features of a keyframe image and their matches between two views
// (OpenCV): the first two steps of the pose refinement (pose_refinement.h).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

struct ImageFeatures {
  std::vector<Eigen::Vector2d> pixels;  // subpixel positions, pixel centres at integers
  std::vector<double> sizes;            // diameters (SIFT scale), pixels
  cv::Mat descriptors;                  // one row per feature (SIFT: 128 floats)
};

// The strongest `max_features` SIFT features of an 8-bit grey image.
ImageFeatures detectFeatures(const ImageViewU8& gray, int max_features);

struct FeatureMatch {
  int reference = 0;  // feature index in the reference view
  int source = 0;     // feature index in the source view
};

struct MatchSet {
  int ratio_matches = 0;              // one-to-one matches that passed the ratio test
  std::vector<FeatureMatch> inliers;  // of those, the RANSAC inliers of an essential matrix
};

// Matches the reference's features to the source's: nearest descriptor with
// Lowe's ratio test (best / second best <= ratio), one-to-one (a source
// feature claimed twice keeps its best match), then the inliers of an
// essential matrix found by RANSAC on the normalised points (threshold in
// pixels of the reference camera's focal length). No inliers when fewer than
// 5 matches pass the ratio test.
MatchSet matchFeatures(const ImageFeatures& reference, const PinholeCamera& reference_camera,
                       const ImageFeatures& source, const PinholeCamera& source_camera, double ratio,
                       double threshold_px);

}  // namespace amhmvs
