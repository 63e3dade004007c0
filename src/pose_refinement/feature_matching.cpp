#include "feature_matching.h"

#include <map>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

namespace amhmvs {

ImageFeatures detectFeatures(const ImageViewU8& gray, int max_features) {
  ImageFeatures features;
  // OpenCV only reads the pixels: the borrowed view is not copied.
  const cv::Mat image(gray.height, gray.width, CV_8UC1, const_cast<uint8_t*>(gray.data));
  std::vector<cv::KeyPoint> keypoints;
  cv::SIFT::create(max_features)->detectAndCompute(image, cv::noArray(), keypoints, features.descriptors);
  // SIFT finds its finest features in the image upsampled x2 and reports
  // them at half that image's coordinates; with pixel centres at integers
  // (resize's convention, ours) the original pixel is 0.25 less.
  constexpr double kUpsamplingOffset = 0.25;
  features.pixels.reserve(keypoints.size());
  features.sizes.reserve(keypoints.size());
  for (const cv::KeyPoint& keypoint : keypoints) {
    features.pixels.emplace_back(keypoint.pt.x - kUpsamplingOffset, keypoint.pt.y - kUpsamplingOffset);
    features.sizes.push_back(keypoint.size);
  }
  return features;
}

namespace {

// A pixel of `camera` as a point on its normalised image plane.
cv::Point2d normalised(const Eigen::Vector2d& pixel, const PinholeCamera& camera) {
  return {(pixel.x() - camera.cx) / camera.fx, (pixel.y() - camera.cy) / camera.fy};
}

}  // namespace

MatchSet matchFeatures(const ImageFeatures& reference, const PinholeCamera& reference_camera,
                       const ImageFeatures& source, const PinholeCamera& source_camera, double ratio,
                       double threshold_px) {
  MatchSet set;
  if (reference.pixels.size() < 2 || source.pixels.size() < 2) return set;
  std::vector<std::vector<cv::DMatch>> candidates;
  cv::BFMatcher(cv::NORM_L2).knnMatch(reference.descriptors, source.descriptors, candidates, 2);
  std::map<int, cv::DMatch> best_for_source;  // one-to-one: a source feature keeps its closest
  for (const std::vector<cv::DMatch>& pair : candidates) {
    if (pair.size() < 2 || pair[0].distance > ratio * pair[1].distance) continue;
    const auto [it, inserted] = best_for_source.emplace(pair[0].trainIdx, pair[0]);
    if (!inserted && pair[0].distance < it->second.distance) it->second = pair[0];
  }
  set.ratio_matches = static_cast<int>(best_for_source.size());
  if (set.ratio_matches < 5) return set;
  std::vector<cv::Point2d> reference_points, source_points;
  std::vector<FeatureMatch> matches;
  for (const auto& [source_index, match] : best_for_source) {
    matches.push_back({match.queryIdx, source_index});
    reference_points.push_back(normalised(reference.pixels[match.queryIdx], reference_camera));
    source_points.push_back(normalised(source.pixels[source_index], source_camera));
  }
  cv::Mat inlier_mask;
  const double focal = 0.5 * (reference_camera.fx + reference_camera.fy);
  const cv::Mat essential = cv::findEssentialMat(reference_points, source_points, cv::Mat::eye(3, 3, CV_64F),
                                                 cv::RANSAC, 0.999, threshold_px / focal, inlier_mask);
  if (essential.empty() || inlier_mask.empty()) return set;
  for (size_t i = 0; i < matches.size(); ++i)
    if (inlier_mask.at<uchar>(static_cast<int>(i))) set.inliers.push_back(matches[i]);
  return set;
}

}  // namespace amhmvs
