// The planar prior of a second estimation pass (not in the paper; after
// ACMP, Xu & Tao 2020): the confident pixels of a first estimate, one per
// cell (the lowest cost), are triangulated in the image (delaunay.h); each
// triangle whose plane agrees with its corners' normals gives that plane to
// the weakly textured pixels it covers (core/texture.h). The second pass adds
// planar_prior_pixel.h's term to every hypothesis's cost and tries the
// prior's plane at each pixel.
#pragma once

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"
#include "amhmvs_mapping/mvs/plane_map.h"

namespace amhmvs {
namespace mvs {

struct PlanarPriorStats {
  int support_points = 0;
  int triangles = 0;       // of the triangulation
  int used_triangles = 0;  // whose plane agrees with their corners
  long covered_pixels = 0; // weakly textured pixels given a prior plane
};

// The prior's planes at the camera's size (depth NaN where none) from a
// first estimate (depth, 3-channel normal and cost at the camera's size) of
// the view whose grey image is `image`. Throws InputError when the sizes
// differ.
PlaneMap planarPrior(const ImageViewU8& image, const ImageViewF& depth, const ImageViewF& normal,
                     const ImageViewF& cost, const PinholeCamera& camera, const PatchMatchOptions& options,
                     PlanarPriorStats* stats = nullptr);

}  // namespace mvs
}  // namespace amhmvs
