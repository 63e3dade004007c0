// Depth problems on the built-in synthetic scene (no data files needed):
// for tests, the benchmark and the demo.
#pragma once

#include <cstdint>

#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

// Three textured slanted planes that meet along creases (two walls at
// 2.5..4 m and a floor), for cameras near the origin looking along +z.
SyntheticWorld makeFoldedPlanesWorld(uint32_t seed);

// The problem (`problem`, borrowing the rendered images it owns) and the
// reference view's true depth.
struct SyntheticProblem : OwnedDepthProblem {
  ImageF true_depth;  // of the reference view; NaN where nothing is hit
};

// Reference camera 0 and `sources` sideways cameras around it (0.15 m
// steps), looking into a fold of three textured slanted planes (two walls and
// a floor meeting along creases); depth range from the true depth widened by
// 10 %.
SyntheticProblem makeSyntheticProblem(int width, int height, int sources, uint32_t seed = 1);
// The same cameras looking into `world`.
SyntheticProblem makeSyntheticProblem(const SyntheticWorld& world, int width, int height, int sources);

}  // namespace amhmvs
