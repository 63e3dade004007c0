// Depth range of a keyframe for the depth estimator, first that works of:
//   1. the range given with the keyframe (Keyframe::depth_min/max), when
//      use_given_range is set;
//   2. its sparse SLAM points: z-depths of the points in front of the camera
//      and inside the image, percentiles low/high_percentile (2/98) widened
//      by near_factor/far_factor (0.8/1.2), with >= min_sparse_points points;
//   3. finished depth maps of overlapping keyframes: their confident depths
//      (every depth_map_stride-th pixel with a matching cost <=
//      max_neighbour_cost; all valid ones when fewer than min_depth_samples
//      are confident) reprojected into this keyframe, the robust percentiles
//      neighbour_low/high_percentile (5/95: a depth map's wrong pixels come in
//      clusters, e.g. a few % at 0.1 m, which must not set the near limit)
//      and the same factors, with >= min_depth_samples samples;
//   4. (store overload, match_when_unknown) before any depth map or point
//      exists, e.g. the first pair of a run: patches of the keyframe matched
//      along epipolar lines in its sources (epipolar_depth_search.h), the
//      same percentiles and factors, with >= min_matched_points depths;
//   5. [default_min, default_max].
// The result is always finite with 0 < min < max; `reason` says which rule
// gave it and why the earlier ones did not.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mapping/epipolar_depth_search.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {

struct DepthRangeOptions {
  bool use_given_range = true;
  double low_percentile = 2.0;    // in [0, 100)
  double high_percentile = 98.0;  // in (low_percentile, 100]
  double near_factor = 0.8;       // in (0, 1]
  double far_factor = 1.2;        // >= 1
  int min_sparse_points = 10;
  int min_depth_samples = 100;
  int depth_map_stride = 2;  // pixel step when reprojecting neighbour depth maps
  // Rule 3: only neighbour pixels whose aggregated matching cost (0..2) is at
  // most this count (a depth map without a cost image counts as confident).
  double max_neighbour_cost = 0.5;
  double neighbour_low_percentile = 5.0;    // in [0, 100)
  double neighbour_high_percentile = 95.0;  // in (neighbour_low_percentile, 100]
  bool match_when_unknown = true;  // rule 4
  int min_matched_points = 20;
  EpipolarSearchOptions matching;
  double default_min = 0.3;  // metres
  double default_max = 30.0;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

enum class DepthRangeSource { kGiven, kSparsePoints, kNeighbourDepthMaps, kMatchedPatches, kDefault };
const char* depthRangeSourceName(DepthRangeSource source);

struct DepthRangeEstimate {
  double min = 0, max = 0;  // z-depth, metres; finite, 0 < min < max
  DepthRangeSource source = DepthRangeSource::kDefault;
  size_t samples = 0;  // points or depth samples behind the estimate
  std::string reason;
};

// A finished depth map of an overlapping keyframe (z-depth, NaN or <= 0 where
// invalid) and optionally its cost image (the estimator's aggregated cost,
// the depth map's size; null: every pixel counts as confident); the pointers
// must stay valid during the call.
struct NeighbourDepth {
  int64_t id = 0;
  const PinholeCamera* camera = nullptr;
  const ImageF* depth = nullptr;
  const ImageF* cost = nullptr;
};

// Throws InputError for invalid options, an invalid keyframe camera, or a
// neighbour with a null pointer, an invalid camera or a depth map whose size
// does not match its camera (naming the neighbour's id).
DepthRangeEstimate estimateDepthRange(const Keyframe& keyframe,
                                      const std::vector<NeighbourDepth>& neighbours,
                                      const DepthRangeOptions& options = DepthRangeOptions());

// Same, for stored keyframe `id` with the finished depth maps of the stored
// `neighbour_ids` (e.g. its selected sources); neighbours without a depth map
// are skipped; rule 4 matches against all of them. Throws InputError for an
// unknown id.
DepthRangeEstimate estimateDepthRange(const KeyframeStore& store, int64_t id,
                                      const std::vector<int64_t>& neighbour_ids,
                                      const DepthRangeOptions& options = DepthRangeOptions());

}  // namespace amhmvs
