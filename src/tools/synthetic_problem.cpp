#include "synthetic_problem.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "amhmvs_mapping/core/synthetic_scene.h"

namespace amhmvs {

SyntheticProblem makeSyntheticProblem(int width, int height, int sources, uint32_t seed) {
  const SyntheticWorld world = makeSlantedPlanesWorld(seed);
  const std::vector<PinholeCamera> cameras = makeSidewaysCameras(sources + 1, width, height);
  SyntheticProblem out;
  for (size_t i = 0; i < cameras.size(); ++i) {
    RenderedView view = renderView(world, cameras[i]);
    if (i == 0) {
      out.problem.reference_camera = view.camera;
      out.problem.reference_image = toGray(view.image);
      out.true_depth = view.depth;
    } else {
      out.problem.source_cameras.push_back(view.camera);
      out.problem.source_images.push_back(toGray(view.image));
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
