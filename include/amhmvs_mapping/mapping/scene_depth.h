// Scene z-depth of a keyframe: the depth at which source selection measures
// overlap and triangulation angles. It comes from the data, first that works:
//   1. the keyframe's sparse points (median z-depth of those in view, at
//      least min_sparse_points);
//   2. the middle of its given depth range;
//   3. its own depth map (median of its valid depths, at least
//      min_depth_samples of them; refinement, fusion);
//   4. the depth maps of the 8 nearest other stored keyframes that look the
//      same way, reprojected into it (median of those in view, at least
//      min_depth_samples);
//   5. bootstrap, before any depth exists (the first pair of a run): image
//      patches matched along epipolar lines in up to max_match_views other
//      keyframes, nearest centres first (median of the matched depths, at
//      least min_matched_points; epipolar_depth_search.h);
//   6. default_scene_depth.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/epipolar_depth_search.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {

struct SceneDepthOptions {
  int min_sparse_points = 5;
  int min_depth_samples = 100;       // depth-map samples (rules 3 and 4)
  bool match_when_unknown = true;    // rule 5
  int max_match_views = 4;
  int min_matched_points = 8;
  EpipolarSearchOptions matching;
  double default_scene_depth = 3.0;  // metres, the last resort

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

struct SceneDepth {
  double depth = 0;    // metres, finite and positive
  std::string source;  // e.g. "median of 120 sparse points", "middle of depth range"
};

// Rules 1, 2 and 6: what the keyframe alone says.
SceneDepth sceneDepth(const Keyframe& keyframe, const SceneDepthOptions& options);

// Every rule, for stored keyframe `id`; rules 4 and 5 use the stored
// keyframes `other_ids` (the candidates of its source selection). Throws
// InputError for an unknown id.
SceneDepth sceneDepth(const KeyframeStore& store, int64_t id, const std::vector<int64_t>& other_ids,
                      const SceneDepthOptions& options);

}  // namespace amhmvs
