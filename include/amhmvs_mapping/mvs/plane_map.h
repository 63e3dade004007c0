// Per-pixel plane maps (a depth map with its normals) carried to another
// camera, as the start (prior_depth / prior_normal) of an estimate:
//   - resamplePlanes: the same view at another scale (coarse_to_fine.h);
//   - reprojectPlanes: other views' maps into a new view (a new keyframe
//     starts from its neighbours' depth; mapping/neighbour_depth.h).
// Both carry planes, not depths: a pixel's plane is evaluated on the ray of
// each pixel it reaches, so both are exact on a plane.
#pragma once

#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mvs/plane_resampling_pixel.h"

namespace amhmvs {
namespace mvs {

struct PlaneMap {
  ImageF depth;   // z-depth, 1 channel; NaN: none
  ImageF normal;  // unit normal in the camera frame, 3 channels; 0 where no depth
};

// The planes of a view at one scale carried to another scale of the same
// view (joint bilateral upsampling when `to` is finer, guided by its image):
// each pixel of `to` evaluates on its own ray the planes of the 3x3 pixels of
// `from` around it and averages those depths and normals with the weights
//   w = exp(-(dx^2 + dy^2) / 2) * exp(-(I_to - I_from)^2 / (2 sigma^2))
// (dx, dy in `from` pixels, intensities 0..255; computed relative to the
// largest, so that they never all underflow). NaN where none of those 3x3
// pixels has a valid plane.
constexpr float kResamplingSigmaIntensity = 10.0f;
inline RayCamera rayCamera(const PinholeCamera& camera) {
  return {camera.fx, camera.fy, camera.cx, camera.cy, camera.width, camera.height};
}
PlaneMap resamplePlanes(const ImageViewF& from_depth, const ImageViewF& from_normal, const PinholeCamera& from_camera,
                        const ImageViewU8& from_image, const PinholeCamera& to_camera, const ImageViewU8& to_image,
                        float sigma_intensity = kResamplingSigmaIntensity);

// One view's plane map with its camera (maps at the camera's size).
struct PlaneMapView {
  PinholeCamera camera;
  ImageViewF depth;   // 1 channel; NaN or <= 0: none
  ImageViewF normal;  // 3 channels
  ImageViewF cost;    // optional matching cost (empty: every valid pixel is used)
};

// Forward warp of the views' planes into `to` (z-buffer, nearest wins): each
// valid pixel whose cost is at most max_cost and whose plane faces `to` is
// carried into `to`'s frame and written to the (2 r + 1)^2 pixels around its
// projection (r = splat_radius), each with the plane's depth on its own ray
// (within kMaxSplatDepthSpread of the point's depth: a splat does not reach
// along grazing planes). NaN where nothing lands. Throws InputError when a
// map's size differs from its camera's.
constexpr float kMaxSplatDepthSpread = 0.05f;  // relative
PlaneMap reprojectPlanes(const std::vector<PlaneMapView>& from, const PinholeCamera& to, float max_cost,
                         int splat_radius = 1);

}  // namespace mvs
}  // namespace amhmvs
