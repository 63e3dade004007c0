// The keyframes whose depth keeps improving with the frames that follow them
// (step 8 of online_mapper.h; not in the paper): each keyframe's first depth
// map starts a KeyframeDepthFilter, every later frame (a keyframe, or a frame
// between keyframes given to OnlineMapper::observe) refines the filters of
// the newest keyframes, and their depth is published again at a bounded
// rate: the filter's converged pixels over the depth published at fusion.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/depth_filter.h"

namespace amhmvs {

struct TemporalDepthOptions {
  bool enabled = false;
  int keyframes = 3;             // the newest keyframes with a depth map that each frame refines
  int frames_per_keyframe = 16;  // frames one keyframe's filter takes; then its depth is final
  int publish_every = 4;         // its depth is published again after this many frames (and when final)
  DepthFilterOptions filter;
  // The filters on the GPU: set by MappingPipeline when its estimator runs
  // there (not a parameter). A filter the GPU cannot start runs on the CPU.
  bool on_gpu = false;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// A keyframe's depth as published again after `frames` frames.
struct RefinedDepth {
  int64_t id = 0;
  double stamp = 0;
  PinholeCamera camera;
  int frames = 0;
  bool final = false;  // the filter took its last frame
  // depth: the filter's converged pixels, elsewhere the depth published at
  // fusion (NaN where neither); confidence: the filter's inlier probability
  // where it converged, the fusion's elsewhere.
  PublishedDepth published;
};

class TemporalDepth {
 public:
  void setOptions(const TemporalDepthOptions& options) { options_ = options; }

  // Keyframe `id`'s first depth map starts its filter (the oldest filter
  // beyond options.keyframes is final now: its depth comes in `out`).
  void start(int64_t id, double stamp, const PinholeCamera& camera, const ImageU8& gray, const DepthMap& estimate,
             std::vector<RefinedDepth>* out);
  // The depth published when `id` was fused: the base the filter improves.
  void setPublished(int64_t id, const PublishedDepth& published);
  // One frame refines every filter but `id`'s own (a keyframe is no frame
  // of itself); the depths due to be published again go to `out`.
  void observe(int64_t id, const PinholeCamera& camera, const ImageU8& gray, std::vector<RefinedDepth>* out);

  size_t active() const { return filters_.size(); }
  // Filters the GPU could not start (run on the CPU instead) or failed
  // during (dropped, their keyframe keeps what was published).
  size_t gpuFailures() const { return gpu_failures_; }
  void forget(int64_t id);
  void clear() { filters_.clear(); }

 private:
  struct Active {
    int64_t id;
    double stamp;
    std::unique_ptr<KeyframeDepthFilter> filter;
    PublishedDepth published;  // at fusion (empty until then)
    int published_frames = 0;  // frames when it was last published again
  };
  RefinedDepth refined(const Active& active, bool final) const;

  TemporalDepthOptions options_;
  std::deque<Active> filters_;  // oldest first
  size_t gpu_failures_ = 0;
};

}  // namespace amhmvs
