// A keyframe's depth map refined over the frames that follow it (temporal
// depth filter, depth_filter_pixel.h; not in the paper). Starts from the
// estimator's depth and normals, measures each pixel again in every frame it
// is given, and publishes the pixels whose belief converged.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/depth_filter_pixel.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

class DeviceDepthFilter;

struct DepthFilterOptions {
  // The start: sigma = initial_sigma * depth around the estimator's depth,
  // inlier ratio Beta(initial_inliers, initial_outliers).
  double initial_sigma = 0.15;
  double initial_inliers = 2;
  double initial_outliers = 1;
  // The measurement's error in pixels (its tau, measurementSigma()).
  double pixel_sigma = 1.0;
  // The search: +- search_sigmas sigma around the belief, search_samples
  // depths; a match needs a matching cost (0..2) below max_cost.
  double search_sigmas = 2.0;
  int search_samples = 32;
  double max_cost = 0.5;
  // Published: sigma <= converged_sigma * depth and an inlier probability of
  // at least min_inlier_probability. 1 % rather than 2 %: on redkitchen
  // (docs/accuracy.md, "Temporal depth filter") 2 % published twice the
  // pixels at 6-11 points less accuracy, 1 % a third more at 2-3 points less.
  double converged_sigma = 0.01;
  double min_inlier_probability = 0.6;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// What one frame did to a keyframe's filter.
struct DepthFilterUpdate {
  size_t matched = 0;      // pixels measured again
  size_t missed = 0;       // seen, no match near the belief: counted against it
  size_t not_visible = 0;  // outside the frame
};

// The per-frame constants of filterPixel (keyframe and frame cameras).
filter::FrameParams frameParams(const PinholeCamera& keyframe, const PinholeCamera& frame,
                                const DepthFilterOptions& options, float depth_range);

class KeyframeDepthFilter {
 public:
  // `gray` (1 channel, the camera's size) and `estimate` (depth, normal) are
  // copied (to the GPU with on_gpu). Throws InputError when sizes or options
  // do not fit, BackendError when on_gpu and no GPU is usable.
  KeyframeDepthFilter(const PinholeCamera& camera, const ImageU8& gray, const DepthMap& estimate,
                      const DepthFilterOptions& options, bool on_gpu = false);
  ~KeyframeDepthFilter();
  KeyframeDepthFilter(const KeyframeDepthFilter&) = delete;
  KeyframeDepthFilter& operator=(const KeyframeDepthFilter&) = delete;

  // One frame (camera and grey image) measures every pixel with a belief.
  // Throws InputError for an image that does not fit its camera.
  DepthFilterUpdate update(const PinholeCamera& frame, const ImageU8& gray);

  int frames() const { return frames_; }
  const PinholeCamera& camera() const { return camera_; }
  // The belief's mean where it converged, NaN elsewhere.
  ImageF depth() const;
  // Every pixel's mean (NaN without a belief) and its sigma and inlier probability.
  ImageF mean() const;
  ImageF sigma() const;
  ImageF inlierProbability() const;
  bool onGpu() const { return device_ != nullptr; }

 private:
  // The beliefs on the host (downloaded from the GPU once per frame they changed).
  const std::vector<filter::DepthBelief>& beliefs() const;

  PinholeCamera camera_;
  ImageU8 gray_;
  ImageF normal_;
  mutable std::vector<filter::DepthBelief> beliefs_;  // sigma2 = 0: none (no estimate at the pixel)
  std::unique_ptr<DeviceDepthFilter> device_;          // on_gpu: the beliefs live there
  mutable bool host_stale_ = false;                    // device_'s beliefs changed since the download
  DepthFilterOptions options_;
  float depth_range_ = 0;  // the outlier model's width: twice the deepest start
  int frames_ = 0;
};

}  // namespace amhmvs
