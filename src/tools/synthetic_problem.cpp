#include "synthetic_problem.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "amhmvs_mapping/simulation/synthetic_scene.h"

namespace amhmvs {

// Three textured slanted planes that meet along creases, seen from inside the
// fold: a left and a right wall at 2.5..4 m and a floor 1.2 m below the
// camera. Depth is continuous everywhere (no occlusion boundary), so every
// pixel is visible in every source view.
SyntheticWorld makeFoldedPlanesWorld(uint32_t seed) {
  SyntheticWorld world;
  const double texture = 0.08;  // finest texture feature, metres (~6 px at 320x240)
  // Walls from the crease x = 0, z = 4 down to the floor at y = 1.2.
  auto wall = [&](double x_end, double z_end, uint32_t texture_seed) {
    return makeTexturedQuad({0, -6, 4}, {x_end, 0, z_end - 4}, {0, 7.2, 0}, texture_seed, texture);
  };
  world.planes.push_back(wall(-6, 2.5, seed * 3 + 1));  // left wall, z = 4 + 0.25 x
  world.planes.push_back(wall(6, 2.8, seed * 3 + 2));   // right wall, z = 4 - 0.2 x
  world.planes.push_back(makeTexturedQuad({-8, 1.2, 0}, {16, 0, 0}, {0, 0, 6}, seed * 3 + 3, texture));
  return world;
}

SyntheticProblem makeSyntheticProblem(int width, int height, int sources, uint32_t seed) {
  return makeSyntheticProblem(makeFoldedPlanesWorld(seed), width, height, sources);
}

SyntheticProblem makeSyntheticProblem(const SyntheticWorld& world, int width, int height, int sources) {
  const std::vector<PinholeCamera> cameras = makeSidewaysCameras(sources + 1, width, height);
  SyntheticProblem out;
  for (size_t i = 0; i < cameras.size(); ++i) {
    RenderedView view = renderView(world, cameras[i]);
    if (i == 0) {
      out.setReference(view.camera, toGray(view.image));
      out.true_depth = view.depth;
    } else {
      out.addSource(view.camera, toGray(view.image));
    }
  }
  float lo = std::numeric_limits<float>::max(), hi = 0;
  for (float d : out.true_depth.data) {
    if (std::isfinite(d)) {
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
  }
  out.problem.depth_min = 0.9 * lo;
  out.problem.depth_max = 1.1 * hi;
  return out;
}

}  // namespace amhmvs
