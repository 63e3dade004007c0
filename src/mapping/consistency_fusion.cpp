#include "amhmvs_mapping/mapping/consistency_fusion.h"

#include <algorithm>

namespace amhmvs {
namespace {

bool hasDepthAndNormals(const StoredKeyframe& stored) {
  return stored.state == KeyframeState::kDone && !stored.depth->depth.empty() && stored.depth->normal.channels == 3;
}

// Borrows the stored keyframe's maps and image (no copy): the store keeps
// them while fusion runs.
FusionView fusionView(int local_id, const StoredKeyframe& stored) {
  FusionView view;
  view.id = local_id;
  view.camera = stored.keyframe.camera;
  view.depth = stored.depth->depth;
  view.normal = stored.depth->normal;
  view.cost = stored.depth->cost;
  view.color = stored.keyframe.image;
  view.key = static_cast<int64_t>(stored.depth_revision);
  return view;
}

}  // namespace

ConsistencyFusion::ConsistencyFusion(const KeyframeStore& store, const MapPoseCorrection& poses, FuseFunction fuse,
                                     PublishFunction publish)
    : store_(store),
      poses_(poses),
      fuse_(fuse ? std::move(fuse) : FuseFunction(fuseDepthMaps)),
      publish_(publish ? std::move(publish) : PublishFunction([](const FusionView& reference,
                                                                   const std::vector<FusionView>& views,
                                                                   const ConfidenceOptions& confidence,
                                                                   const ConfidenceCalibration& calibration) {
        return publishDepth(reference, views, confidence, calibration);
      })) {}

size_t ConsistencyFusion::viewCap() const {
  return static_cast<size_t>(
      std::min(kMaxSourceViews, std::max(options_.sources.max_sources, options_.fusion.min_consistent_views)));
}

size_t ConsistencyFusion::requiredViews() const {
  return static_cast<size_t>(std::max(1, options_.fusion.min_consistent_views));
}

std::vector<int64_t> ConsistencyFusion::views(int64_t id) const {
  SourceSelectionOptions options = options_.sources;
  options.max_sources = static_cast<int>(viewCap());
  options.max_candidates = std::max(options.max_candidates, options.max_sources);
  const std::vector<int64_t> candidates = store_.nearestIds(
      store_.keyframe(id).camera.center(), nearestCandidateCount(options), id, hasDepthAndNormals);
  if (candidates.empty()) return {};
  // Through the store: the scene depth is the keyframe's own depth map's.
  return selectSources(store_, id, candidates, options).source_ids;
}

// The consistency views have no sources of their own: they only support.
std::vector<FusionView> ConsistencyFusion::fusionViews(int64_t id, const std::vector<int64_t>& view_ids) const {
  const PinholeCamera& camera = store_.keyframe(id).camera;
  std::vector<FusionView> views;
  for (int64_t view : view_ids) {
    views.push_back(fusionView(static_cast<int>(views.size()), store_.entry(view)));
    if (options_.at_refined_poses) poses_.placeView(id, camera, view, &views.back().camera);
  }
  return views;
}

PublishedDepth ConsistencyFusion::publish(int64_t id, const std::vector<int64_t>& view_ids) const {
  const StoredKeyframe& stored = store_.entry(id);
  if (!hasDepthAndNormals(stored)) return {};
  const std::vector<FusionView> views = fusionViews(id, view_ids);
  return publish_(fusionView(static_cast<int>(views.size()), stored), views, options_.confidence,
                  defaultConfidenceCalibration());
}

KeyframePoints ConsistencyFusion::fuse(int64_t id, const std::vector<int64_t>& view_ids) const {
  // The keyframe is view n after the consistency views.
  std::vector<FusionView> views = fusionViews(id, view_ids);
  const StoredKeyframe& stored = store_.entry(id);
  if (views.empty() || !hasDepthAndNormals(stored)) return {};
  FusionView reference = fusionView(static_cast<int>(views.size()), stored);
  for (const FusionView& view : views) reference.source_ids.push_back(view.id);
  views.push_back(std::move(reference));
  // min_consistent_views as configured: never fewer than asked for.
  FusionResult fused = fuse_(views, options_.fusion);
  return std::move(fused.views.back().points);
}

}  // namespace amhmvs
