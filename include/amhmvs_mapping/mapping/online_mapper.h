// The online mapping pipeline, one keyframe at a time (ROS-free; the mapping
// nodelet is a thin layer on top of it):
//
//   1. store the keyframe (KeyframeStore, bounded);
//   2. choose its source views among the stored keyframes (selectSources);
//      none: it is kept as a source for later keyframes, marked done without
//      depth (an all-NaN depth map, no normals), nothing else happens;
//   3. its depth range (estimateDepthRange: given, sparse points, the
//      sources' depth maps, default);
//   4. its depth map (the injected estimate function: the caller's backend
//      with its fallbacks);
//   5. fusion of its depth map against the sources that have one
//      (fuseDepthMaps; min_consistent_views is capped at that number, so the
//      second keyframe of a run is checked against the one depth map there
//      is); its fused points (camera frame) are stored with it;
//   6. those points into the global VoxelMap at the keyframe's pose.
//
// Loop closure: updatePose() re-poses the keyframe in the store and moves its
// points in the map exactly (remove with the old pose, add with the new one).
// Keyframes evicted from the store stay in the map (the map has its own
// bounds and keeps their points, so they can still be re-posed).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/depth_range.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/source_selection.h"
#include "amhmvs_mapping/mapping/voxel_map.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct OnlineMapperOptions {
  KeyframeStoreOptions store;
  SourceSelectionOptions sources;
  DepthRangeOptions depth_range;
  FusionOptions fusion = FusionOptions::reprojection();
  VoxelMapOptions map;

  // Empty when valid; otherwise one line per problem, prefixed by the group.
  std::string validate() const;
};

// Depth estimation as the mapper calls it. Throws like DepthEstimator::estimate.
using EstimateFunction = std::function<DepthMap(const DepthProblem&)>;

// What process() did with one keyframe.
struct KeyframeResult {
  int64_t id = 0;
  SourceSelection selection;
  bool has_depth = false;        // false: no source view, stored as a source only
  DepthRangeEstimate depth_range;  // when has_depth
  DepthMap depth;                // when has_depth
  PinholeCamera camera;          // the keyframe's camera (pose used)
  int fusion_sources = 0;        // sources with a depth map the fusion checked against
  KeyframePoints points;         // fused points, camera frame (empty without fusion sources)
  VoxelMapUpdate map_update;
  std::vector<int64_t> evicted;  // keyframes evicted from the store
};

class OnlineMapper {
 public:
  // Throws InputError when the options are invalid or estimate is empty.
  OnlineMapper(const OnlineMapperOptions& options, EstimateFunction estimate);

  // Runs steps 1-6 for a keyframe. Throws InputError for an invalid keyframe
  // (nothing changes); an exception of the estimate function propagates after
  // the keyframe was removed from the store again.
  KeyframeResult process(Keyframe keyframe);

  // Loop closure: new camera-to-world pose of a stored keyframe; moves its map
  // points. False when the id is not (or no longer) stored. Throws InputError
  // for a bad pose.
  bool updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world);

  // Forgets every keyframe and empties the map.
  void reset();

  // Options that may change while running (dynamic reconfigure); the store
  // and map bounds stay. Throws InputError (nothing changes) when invalid.
  void setOptions(const OnlineMapperOptions& options);

  const KeyframeStore& store() const { return store_; }
  const VoxelMap& map() const { return map_; }
  const OnlineMapperOptions& options() const { return options_; }
  // Incremented by every change of the map (add, re-pose, reset).
  uint64_t mapRevision() const { return map_revision_; }

 private:
  // Fuses keyframe `id`'s depth map against its sources' depth maps.
  KeyframePoints fuse(int64_t id, const std::vector<int64_t>& source_ids, int* fusion_sources) const;

  OnlineMapperOptions options_;
  EstimateFunction estimate_;
  KeyframeStore store_;
  VoxelMap map_;
  uint64_t map_revision_ = 0;
};

}  // namespace amhmvs
