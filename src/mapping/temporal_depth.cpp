#include "amhmvs_mapping/mapping/temporal_depth.h"

#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

std::string TemporalDepthOptions::validate() const {
  std::ostringstream why;
  if (keyframes < 1 || keyframes > 16) why << "keyframes must be in [1, 16] (got " << keyframes << ")\n";
  if (frames_per_keyframe < 1) why << "frames_per_keyframe must be >= 1 (got " << frames_per_keyframe << ")\n";
  if (publish_every < 1) why << "publish_every must be >= 1 (got " << publish_every << ")\n";
  why << filter.validate();
  return why.str();
}

void TemporalDepth::start(int64_t id, double stamp, const PinholeCamera& camera, const ImageU8& gray,
                          const DepthMap& estimate, std::vector<RefinedDepth>* out) {
  forget(id);
  std::unique_ptr<KeyframeDepthFilter> filter;
  if (options_.on_gpu) {
    try {
      filter = std::make_unique<KeyframeDepthFilter>(camera, gray, estimate, options_.filter, /*on_gpu=*/true);
    } catch (const BackendError&) {
      ++gpu_failures_;
    }
  }
  if (!filter) filter = std::make_unique<KeyframeDepthFilter>(camera, gray, estimate, options_.filter);
  filters_.push_back({id, stamp, std::move(filter), {}, 0});
  while (filters_.size() > static_cast<size_t>(options_.keyframes)) {
    // Final now; published again only with frames since its last publication.
    const Active& oldest = filters_.front();
    if (oldest.filter->frames() > oldest.published_frames) out->push_back(refined(oldest, /*final=*/true));
    filters_.pop_front();
  }
}

void TemporalDepth::setPublished(int64_t id, const PublishedDepth& published) {
  for (Active& active : filters_)
    if (active.id == id) active.published = published;
}

void TemporalDepth::observe(int64_t id, const PinholeCamera& camera, const ImageU8& gray,
                            std::vector<RefinedDepth>* out) {
  for (auto it = filters_.begin(); it != filters_.end();) {
    if (it->id == id) {
      ++it;
      continue;
    }
    try {
      it->filter->update(camera, gray);
    } catch (const BackendError&) {
      ++gpu_failures_;
      it = filters_.erase(it);
      continue;
    }
    const int frames = it->filter->frames();
    const bool final = frames >= options_.frames_per_keyframe;
    if (final || frames % options_.publish_every == 0) {
      out->push_back(refined(*it, final));
      it->published_frames = frames;
    }
    it = final ? filters_.erase(it) : it + 1;
  }
}

void TemporalDepth::forget(int64_t id) {
  for (auto it = filters_.begin(); it != filters_.end(); ++it) {
    if (it->id != id) continue;
    filters_.erase(it);
    return;
  }
}

RefinedDepth TemporalDepth::refined(const Active& active, bool final) const {
  RefinedDepth out;
  out.id = active.id;
  out.stamp = active.stamp;
  out.camera = active.filter->camera();
  out.frames = active.filter->frames();
  out.final = final;
  const ImageF converged = active.filter->depth();
  const ImageF inliers = active.filter->inlierProbability();
  out.published = active.published;
  if (out.published.depth.empty()) out.published.depth = ImageF(converged.width, converged.height, 1, std::nanf(""));
  if (out.published.confidence.empty())
    out.published.confidence = ImageF(converged.width, converged.height, 1, 0.0f);
  for (size_t i = 0; i < converged.data.size(); ++i) {
    if (!std::isfinite(converged.data[i])) continue;
    out.published.depth.data[i] = converged.data[i];
    out.published.confidence.data[i] = inliers.data[i];
  }
  return out;
}

}  // namespace amhmvs
