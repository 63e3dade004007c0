#include "amhmvs_mapping/mapping/depth_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"
#include "amhmvs_mapping/mvs/view_geometry.h"
#include "depth_filter_device.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool hasBelief(const filter::DepthBelief& belief) { return belief.sigma2 > 0; }

std::string imageProblem(const PinholeCamera& camera, const ImageU8& gray) {
  if (gray.channels != 1) return "needs a grey image (1 channel), got " + std::to_string(gray.channels);
  if (gray.width != camera.width || gray.height != camera.height)
    return "image " + std::to_string(gray.width) + "x" + std::to_string(gray.height) + " does not fit its camera " +
           std::to_string(camera.width) + "x" + std::to_string(camera.height);
  return camera.validate();
}

}  // namespace

filter::FrameParams frameParams(const PinholeCamera& keyframe, const PinholeCamera& frame,
                                const DepthFilterOptions& options, float depth_range) {
  filter::FrameParams p;
  p.frame = mvs::sourceGeometry(keyframe, frame, /*layer=*/0);
  const RelativePose relative = relativePose(keyframe, frame);
  const Eigen::Vector3d centre = -relative.R.transpose() * relative.t;
  p.frame_centre = {static_cast<float>(centre.x()), static_cast<float>(centre.y()), static_cast<float>(centre.z())};
  p.keyframe = mvs::intrinsicsOf(keyframe);
  const PatchMatchOptions window;  // the estimator's window and weights (PaperWindow's shape)
  p.search.cost = {window.window_radius, window.window_step, window.sigma_color, window.sigma_spatial};
  p.search.samples = options.search_samples;
  p.search.max_cost = static_cast<float>(options.max_cost);
  p.pixel_angle = 2.0f * std::atan(static_cast<float>(options.pixel_sigma) / (2.0f * p.keyframe.fx));
  p.search_sigmas = static_cast<float>(options.search_sigmas);
  p.depth_range = depth_range;
  return p;
}

std::string DepthFilterOptions::validate() const {
  std::ostringstream why;
  const auto positive = [&why](const char* name, double value) {
    if (!(std::isfinite(value) && value > 0)) why << name << " must be finite and > 0 (got " << value << ")\n";
  };
  positive("initial_sigma", initial_sigma);
  positive("initial_inliers", initial_inliers);
  positive("initial_outliers", initial_outliers);
  positive("pixel_sigma", pixel_sigma);
  positive("search_sigmas", search_sigmas);
  positive("converged_sigma", converged_sigma);
  if (search_samples < 3 || search_samples > 256)
    why << "search_samples must be in [3, 256] (got " << search_samples << ")\n";
  if (!(max_cost > 0 && max_cost <= mvs::kMaxCost))
    why << "max_cost must be in (0, " << mvs::kMaxCost << "] (got " << max_cost << ")\n";
  if (!(min_inlier_probability >= 0 && min_inlier_probability < 1))
    why << "min_inlier_probability must be in [0, 1) (got " << min_inlier_probability << ")\n";
  return why.str();
}

KeyframeDepthFilter::KeyframeDepthFilter(const PinholeCamera& camera, const ImageU8& gray, const DepthMap& estimate,
                                         const DepthFilterOptions& options, bool on_gpu)
    : camera_(camera), gray_(gray), normal_(estimate.normal), options_(options) {
  std::string problem = options.validate();
  if (!problem.empty()) throw InputError("depth filter options:\n" + problem);
  problem = imageProblem(camera, gray);
  if (!problem.empty()) throw InputError("depth filter keyframe: " + problem);
  if (estimate.depth.width != camera.width || estimate.depth.height != camera.height ||
      estimate.normal.width != camera.width || estimate.normal.height != camera.height ||
      estimate.normal.channels != 3)
    throw InputError("depth filter keyframe: the depth map (depth and 3-channel normals) must be the camera's size");
  beliefs_.assign(static_cast<size_t>(camera.width) * camera.height, filter::DepthBelief{0, 0, 0, 0});
  float deepest = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const float depth = estimate.depth.at(x, y);
      if (!(std::isfinite(depth) && depth > 0)) continue;
      const float sigma = static_cast<float>(options.initial_sigma) * depth;
      beliefs_[static_cast<size_t>(y) * camera.width + x] = {depth, sigma * sigma,
                                                              static_cast<float>(options.initial_inliers),
                                                              static_cast<float>(options.initial_outliers)};
      deepest = std::max(deepest, depth);
    }
  }
  depth_range_ = 2 * deepest;
  if (on_gpu) device_ = makeCudaDepthFilter(gray_, normal_, beliefs_);
}

KeyframeDepthFilter::~KeyframeDepthFilter() = default;

const std::vector<filter::DepthBelief>& KeyframeDepthFilter::beliefs() const {
  if (host_stale_) {
    device_->download(&beliefs_);
    host_stale_ = false;
  }
  return beliefs_;
}

DepthFilterUpdate KeyframeDepthFilter::update(const PinholeCamera& frame, const ImageU8& gray) {
  const std::string problem = imageProblem(frame, gray);
  if (!problem.empty()) throw InputError("depth filter frame: " + problem);
  DepthFilterUpdate outcome;
  ++frames_;
  if (!(depth_range_ > 0)) return outcome;
  const filter::FrameParams params = frameParams(camera_, frame, options_, depth_range_);
  if (device_) {
    host_stale_ = true;
    return device_->update(params, gray);
  }
  const mvs::PaddedImage8 padded{ImageViewU8(gray)};
  const mvs::CpuSourceView view{padded.origin, padded.stride, padded.width + mvs::kCoordinateMargin,
                                padded.height + mvs::kCoordinateMargin};
  mvs::CpuSampler keyframe;
  keyframe.reference_image = ImageViewU8(gray_);
  size_t matched = 0, missed = 0, not_visible = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : matched, missed, not_visible)
  for (int y = 0; y < camera_.height; ++y) {
    mvs::ReferenceWindow window;
    for (int x = 0; x < camera_.width; ++x) {
      const mvs::Vec3 normal{normal_.at(x, y, 0), normal_.at(x, y, 1), normal_.at(x, y, 2)};
      switch (filter::filterPixel<mvs::PaperWindow>(keyframe, view, params, normal, x, y, &window,
                                                     &beliefs_[static_cast<size_t>(y) * camera_.width + x])) {
        case filter::PixelOutcome::kMatched: ++matched; break;
        case filter::PixelOutcome::kMissed: ++missed; break;
        case filter::PixelOutcome::kNotVisible: ++not_visible; break;
        case filter::PixelOutcome::kSkipped: break;
      }
    }
  }
  outcome.matched = matched;
  outcome.missed = missed;
  outcome.not_visible = not_visible;
  return outcome;
}

ImageF KeyframeDepthFilter::mean() const {
  const std::vector<filter::DepthBelief>& all = beliefs();
  ImageF out(camera_.width, camera_.height, 1, kNaN);
  for (size_t i = 0; i < all.size(); ++i)
    if (hasBelief(all[i])) out.data[i] = all[i].mu;
  return out;
}

ImageF KeyframeDepthFilter::sigma() const {
  const std::vector<filter::DepthBelief>& all = beliefs();
  ImageF out(camera_.width, camera_.height, 1, kNaN);
  for (size_t i = 0; i < all.size(); ++i)
    if (hasBelief(all[i])) out.data[i] = std::sqrt(all[i].sigma2);
  return out;
}

ImageF KeyframeDepthFilter::inlierProbability() const {
  const std::vector<filter::DepthBelief>& all = beliefs();
  ImageF out(camera_.width, camera_.height, 1, kNaN);
  for (size_t i = 0; i < all.size(); ++i)
    if (hasBelief(all[i])) out.data[i] = filter::inlierProbability(all[i]);
  return out;
}

ImageF KeyframeDepthFilter::depth() const {
  ImageF out(camera_.width, camera_.height, 1, kNaN);
  const float converged = static_cast<float>(options_.converged_sigma);
  const float min_inliers = static_cast<float>(options_.min_inlier_probability);
  const std::vector<filter::DepthBelief>& all = beliefs();
  for (size_t i = 0; i < all.size(); ++i) {
    const filter::DepthBelief& belief = all[i];
    if (!hasBelief(belief)) continue;
    if (std::sqrt(belief.sigma2) <= converged * belief.mu && filter::inlierProbability(belief) >= min_inliers)
      out.data[i] = belief.mu;
  }
  return out;
}

}  // namespace amhmvs
