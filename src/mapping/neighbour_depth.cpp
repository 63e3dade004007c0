#include "amhmvs_mapping/mapping/neighbour_depth.h"

#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/option_field.h"

namespace amhmvs {
namespace {

// A depth map with normals (a keyframe stored as a source only has neither).
const DepthMap* planesOf(const StoredKeyframe& stored) {
  const DepthMap& map = stored.depth;
  const bool usable = stored.state == KeyframeState::kDone && !map.depth.empty() && map.normal.channels == 3;
  return usable ? &map : nullptr;
}

}  // namespace

const char* neighbourStartName(NeighbourDepthOptions::Start start) {
  switch (start) {
    case NeighbourDepthOptions::Start::kOff: return "false";
    case NeighbourDepthOptions::Start::kOn: return "true";
    case NeighbourDepthOptions::Start::kAuto: break;
  }
  return "auto";
}

NeighbourDepthOptions::Start parseNeighbourStart(const std::string& text) {
  if (text == "auto") return NeighbourDepthOptions::Start::kAuto;
  try {
    return parseSwitchText("start_from_neighbours", text) ? NeighbourDepthOptions::Start::kOn
                                                          : NeighbourDepthOptions::Start::kOff;
  } catch (const InputError&) {
    throw InputError("option start_from_neighbours: '" + text + "' is not true, false or auto");
  }
}

std::string NeighbourDepthOptions::validate() const {
  std::ostringstream why;
  if (start_iterations < 0 || start_iterations > 100)
    why << "start_iterations must be in 0..100 (got " << start_iterations << ")\n";
  if (!(std::isfinite(start_max_cost) && start_max_cost >= 0))
    why << "start_max_cost must be finite and >= 0 (got " << start_max_cost << ")\n";
  if (geometric_iterations < 1 || geometric_iterations > 100)
    why << "geometric_iterations must be in 1..100 (got " << geometric_iterations << ")\n";
  return why.str();
}

NeighbourDepthInputs attachNeighbourDepth(const KeyframeStore& store, int64_t id, const std::vector<int64_t>& sources,
                                          bool refinement, const NeighbourDepthOptions& options,
                                          DepthProblem* problem) {
  NeighbourDepthInputs inputs;
  if (refinement && options.geometric_refinement) {
    for (int64_t source : sources) {
      const DepthMap* map = planesOf(store.entry(source));
      problem->source_depths.push_back(map ? ImageViewF(map->depth) : ImageViewF());
      inputs.geometric_sources += map != nullptr;
    }
    const DepthMap* own = planesOf(store.entry(id));
    if (own) {
      problem->prior_depth = own->depth;
      problem->prior_normal = own->normal;
      problem->prior_iterations = options.geometric_iterations;
    }
    return inputs;
  }
  if (refinement || !options.startsFromNeighbours()) return inputs;
  std::vector<mvs::PlaneMapView> neighbours;
  for (int64_t source : sources) {
    const StoredKeyframe& stored = store.entry(source);
    if (const DepthMap* map = planesOf(stored)) {
      neighbours.push_back({stored.keyframe.camera, map->depth, map->normal, map->cost});
    }
  }
  if (neighbours.empty()) return inputs;
  inputs.start = mvs::reprojectPlanes(neighbours, problem->reference_camera, static_cast<float>(options.start_max_cost));
  for (const float depth : inputs.start.depth.data) inputs.start_pixels += depth > 0.0f;
  if (inputs.start_pixels == 0) return inputs;
  problem->prior_depth = inputs.start.depth;
  problem->prior_normal = inputs.start.normal;
  problem->prior_iterations = options.start_iterations;
  return inputs;
}

}  // namespace amhmvs
