// The estimator uses what an online mapper knows (issue 12): the depth maps
// its neighbours already have. Two switches, both off by default:
//   - start_from_neighbours: a keyframe's estimate starts from its sources'
//     depth maps reprojected into it (mvs::reprojectPlanes: their confident
//     pixels, z-buffer, planes evaluated per pixel), random planes where
//     nothing lands, so that it starts near the answer;
//   - geometric_refinement: a refined keyframe (OnlineMapper::refine) is
//     estimated with the geometric-consistency term against its sources'
//     depth maps (mvs/geometric_consistency.h, as amhmvs_depth --geometric),
//     from its own depth map, for geometric_iterations of local refinement.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/plane_map.h"

namespace amhmvs {

struct NeighbourDepthOptions {
  bool start_from_neighbours = false;
  // Iterations from that start: 0 runs the estimator's schedule (e.g. 6 from
  // iteration 0); N > 0 runs N of local refinement (DepthProblem::prior_iterations).
  int start_iterations = 0;
  // Neighbour pixels with a matching cost (0..2) above this are not carried.
  double start_max_cost = 0.5;
  bool geometric_refinement = false;
  int geometric_iterations = 3;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// What attachNeighbourDepth() gave a problem; it owns the start's pixels,
// which the problem borrows: keep it while the problem is used.
struct NeighbourDepthInputs {
  mvs::PlaneMap start;           // empty unless the start came from the neighbours
  size_t start_pixels = 0;       // pixels of the start with a plane
  size_t geometric_sources = 0;  // sources whose depth maps the geometric term uses
};

// Adds to `problem` (keyframe `id` of `store` with `sources`, its images and
// cameras set) what the options switch on: for a refinement (`refinement`)
// the geometric inputs, else the start from the sources' depth maps. Sources
// without a depth map (sources only, not estimated yet) add nothing.
NeighbourDepthInputs attachNeighbourDepth(const KeyframeStore& store, int64_t id, const std::vector<int64_t>& sources,
                                          bool refinement, const NeighbourDepthOptions& options,
                                          DepthProblem* problem);

}  // namespace amhmvs
