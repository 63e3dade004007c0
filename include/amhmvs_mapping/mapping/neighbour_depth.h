// The estimator uses what an online mapper knows (issue 12): the depth maps
// its neighbours already have. Two switches:
//   - start_from_neighbours (auto: on with the CPU estimator): a keyframe's
//     estimate starts from its sources' depth maps reprojected into it
//     (mvs::reprojectPlanes: their confident pixels, z-buffer, planes
//     evaluated per pixel), random planes where nothing lands, so that it
//     starts near the answer and runs start_iterations of local refinement
//     (2) instead of the full schedule;
//   - geometric_refinement (off): a refined keyframe (OnlineMapper::refine) is
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
  // kAuto: on with the CPU estimator, where the iterations it saves cost far
  // more than the reprojection (redkitchen at 320x240, 4 sources: 10 ms for
  // 160 ms less estimate), off with CUDA, where the reprojection runs on the
  // host and would cost more than a whole estimate.
  enum class Start { kOff, kOn, kAuto };
  Start start_from_neighbours = Start::kAuto;
  // Iterations from that start: 0 runs the estimator's schedule (e.g. 6 from
  // iteration 0); N > 0 runs N of local refinement (DepthProblem::prior_iterations).
  int start_iterations = 2;
  bool on_gpu = false;  // the estimator's backend is CUDA (set by MappingPipeline)
  bool startsFromNeighbours() const {
    return start_from_neighbours == Start::kOn || (start_from_neighbours == Start::kAuto && !on_gpu);
  }
  // Neighbour pixels with a matching cost (0..2) above this are not carried.
  double start_max_cost = 0.5;
  bool geometric_refinement = false;
  int geometric_iterations = 3;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// "false", "true", "auto"; the parser also takes 1/0, yes/no and an empty
// text (a bare command-line switch: true) and throws InputError otherwise.
const char* neighbourStartName(NeighbourDepthOptions::Start start);
NeighbourDepthOptions::Start parseNeighbourStart(const std::string& text);

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
