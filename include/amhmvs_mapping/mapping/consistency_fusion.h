#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/map_pose_correction.h"
#include "amhmvs_mapping/mapping/source_selection.h"

namespace amhmvs {

// Fusion as the mapper calls it (fuseDepthMaps, or a DepthMapFuser on the
// GPU). Views carry keys (FusionView::key) unique to each depth map.
using FuseFunction = std::function<FusionResult(const std::vector<FusionView>&, const FusionOptions&)>;

// The options step 5 reads (OnlineMapperOptions holds them).
struct ConsistencyFusionOptions {
  SourceSelectionOptions sources;
  FusionOptions fusion;
  ConfidenceOptions confidence;
  // The views at the poses the pose refinement found relative to the
  // keyframe (pose_refinement.enabled && pose_refinement.in_fusion).
  bool at_refined_poses = false;
};

// Step 5 of online_mapper.h for one keyframe, against the store as it is:
// which other depth maps are its consistency views, its points fused against
// them and its depth as published. Keeps nothing between calls.
class ConsistencyFusion {
 public:
  // Reads `store` and `poses` (which outlive it). Without a fuse function it
  // fuses with fuseDepthMaps, without a publish function with publishDepth
  // (both on the CPU).
  ConsistencyFusion(const KeyframeStore& store, const MapPoseCorrection& poses, FuseFunction fuse,
                    PublishFunction publish);

  void setOptions(const ConsistencyFusionOptions& options) { options_ = options; }

  // The most consistency views a keyframe is fused against.
  size_t viewCap() const;
  // The fewest (fusion.min_consistent_views, at least 1; never capped).
  size_t requiredViews() const;
  // The other stored depth maps that pass source selection against `id`,
  // best first, at most viewCap().
  std::vector<int64_t> views(int64_t id) const;
  // `id`'s depth map fused against `view_ids` (camera frame; empty without a depth map).
  KeyframePoints fuse(int64_t id, const std::vector<int64_t>& view_ids) const;
  // Its confidence and published depth against the same views.
  PublishedDepth publish(int64_t id, const std::vector<int64_t>& view_ids) const;

 private:
  // The views as fusion reads them: local ids 0..n-1.
  std::vector<FusionView> fusionViews(int64_t id, const std::vector<int64_t>& view_ids) const;

  const KeyframeStore& store_;
  const MapPoseCorrection& poses_;
  FuseFunction fuse_;
  PublishFunction publish_;
  ConsistencyFusionOptions options_;
};

}  // namespace amhmvs
