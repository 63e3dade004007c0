// Deterministic synthetic multi-view scenes: textured planes and spheres,
// rendered by per-pixel ray casting with ground-truth depth and normals.
//
// The surface radiance is Lambertian and a pure function of the 3D surface
// point (a procedural texture in surface coordinates), so every view sees the
// same colours; this makes the renderings usable to test multi-view stereo
// against exact ground truth. Everything is deterministic: the same inputs
// give the same bytes, whatever the number of OpenMP threads.
//
// Texture: band-limited value noise (three octaves, finest lattice spacing
// `texture_scale` metres) plus soft-edged blobs, intensities in (30, 225) at
// full contrast. Choose `texture_scale` so that it covers a few pixels at the
// viewing distance (about 5 pixels: scale ~ 5 * depth / fx).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

// A textured planar parallelogram origin + a*axis_u + b*axis_v, a, b in [0, 1]
// (or the whole plane when `bounded` is false). The axes must not be parallel.
// Both sides are visible and textured alike. Texture coordinates are
// (a*|axis_u|, b*|axis_v|) metres.
struct SyntheticPlane {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_v = Eigen::Vector3d::UnitY();
  bool bounded = true;
  uint32_t texture_seed = 0;
  double texture_scale = 0.1;     // finest texture feature size, metres (> 0)
  double texture_contrast = 1.0;  // 1: full contrast; < 1: weakly textured
};

// A bounded textured quad origin + a u + b v, a, b in [0, 1].
SyntheticPlane makeTexturedQuad(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis_u,
                                const Eigen::Vector3d& axis_v, uint32_t texture_seed,
                                double texture_scale, double texture_contrast = 1.0);

// A textured sphere (a curved surface), visible from outside and inside. The
// texture is a 3D solid texture evaluated at (point - center) in world axes.
struct SyntheticSphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 1.0;
  uint32_t texture_seed = 0;
  double texture_scale = 0.1;
  double texture_contrast = 1.0;
};

// A scene. Rays that hit nothing see black (intensity 0) and have NaN depth.
struct SyntheticWorld {
  std::vector<SyntheticPlane> planes;
  std::vector<SyntheticSphere> spheres;
};

// Appends the 6 faces of a box of full extents `size` centred at `center`,
// rotated by `yaw` radians about the world axis `up` (unit; default +z). Each
// face gets its own texture seed derived from `texture_seed`.
void addBox(SyntheticWorld& world, const Eigen::Vector3d& center, const Eigen::Vector3d& size,
            double yaw, uint32_t texture_seed, double texture_scale,
            const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

// The nearest surface along a world ray origin + s*direction, s > 0.
struct RayHit {
  bool hit = false;
  double s = 0;                                     // ray parameter of the hit
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // world
  Eigen::Vector3d normal = Eigen::Vector3d::Zero(); // world, unit, against the ray
  Eigen::Vector3d color = Eigen::Vector3d::Zero();  // RGB radiance in [0, 255]
};
// Casts one ray (direction need not be unit). For a camera ray with direction
// R^T * (x, y, 1), `s` is the z-depth of the hit in that camera.
RayHit castRay(const SyntheticWorld& world, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction);

// Z-depth of the first surface through the (sub-)pixel (u, v) of `camera`,
// computed exactly as renderView computes it; NaN when nothing is hit.
double depthAt(const SyntheticWorld& world, const PinholeCamera& camera, double u, double v);

struct RenderedView {
  PinholeCamera camera;
  ImageU8 image;   // RGB, 3 channels, box average of supersampling^2 rays
  ImageF depth;    // z-depth of the pixel-centre ray; NaN where nothing is hit
  ImageF normal;   // 3 channels, unit, camera frame, facing the camera; NaN where nothing
};

// Renders one view. supersampling N in [1, 16] casts N x N rays per pixel on a
// regular grid inside the pixel (offsets (i + 0.5)/N - 0.5) and averages their
// colours; depth and normal come from one ray through the pixel centre.
// Throws InputError for an invalid camera, world or supersampling.
RenderedView renderView(const SyntheticWorld& world, const PinholeCamera& camera,
                        int supersampling = 3);

// The poses one image row is exposed from (rolling shutter, motion blur):
// `mid`, the row's pose at mid exposure, gives its depth and normal; the
// row's colour is the mean over `samples` (poses across the exposure time),
// or the render at `mid` when `samples` is empty. Intrinsics and image size
// must be those of the view's camera.
struct RowExposure {
  PinholeCamera mid;
  std::vector<PinholeCamera> samples;
};

// A pixel's stored level from its mean radiance (RGB in [0, 255]): renderView
// rounds and clips; a sensor model adds gain and noise first. Called from
// several threads at once.
using RadianceToLevel = std::function<uint8_t(double radiance, int x, int y, int channel)>;

// Rounds to the nearest level and clips to 0..255 (renderView's conversion).
uint8_t radianceToByte(double radiance);

// renderView with a pose per row (row_exposure(y), called once per row, in
// order, before any ray is cast) and a conversion of radiance to levels. Each ray is cast
// as renderView casts it, so with row_exposure(y) = {camera, {}} and
// radianceToByte it returns renderView's result bit for bit. Rays per pixel:
// supersampling^2 times the number of samples. `camera` is the view's
// nominal camera (RenderedView::camera).
RenderedView renderViewByRows(const SyntheticWorld& world, const PinholeCamera& camera,
                              const std::function<RowExposure(int row)>& row_exposure, int supersampling,
                              const RadianceToLevel& to_level);

// A camera at `eye` looking at `target`, image x axis horizontal with respect
// to `up` (world up, need not be unit), fx = fy = focal_ratio * width,
// principal point at the image centre ((width-1)/2, (height-1)/2).
// Throws InputError if the viewing direction is parallel to `up`.
PinholeCamera makeLookAtCamera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                               const Eigen::Vector3d& up, int width, int height,
                               double focal_ratio = 0.8);

// Test scene, world frame = optical frame of the central camera (x right,
// y down, z forward): a large textured back wall at z = 6 m and three slanted
// textured quads between 2 and 5 m. `seed` jitters the geometry and textures.
SyntheticWorld makeSlantedPlanesWorld(uint32_t seed);

// `count` cameras for makeSlantedPlanesWorld: camera 0 at the origin, the
// others alternately right and left of it (+b, -b, +2b, -2b, ...) along x,
// all turned to look at the point (0, 0, convergence_distance) (a
// non-positive distance gives parallel cameras looking along +z).
// fx = fy = focal_ratio * width, principal point at the image centre.
std::vector<PinholeCamera> makeSidewaysCameras(int count, int width, int height,
                                               double baseline = 0.15,
                                               double convergence_distance = 4.0,
                                               double focal_ratio = 0.8);

// Indoor scene, world frame z up: a closed room x in [0, 6], y in [0, 5],
// z in [0, 2.6] m (floor, ceiling, four walls, part of the x = 6 wall weakly
// textured), two boxes on the floor with a third stacked on one, a slanted
// ramp and a sphere resting on the floor. `seed` jitters objects and textures.
SyntheticWorld makeIndoorRoomWorld(uint32_t seed);

// `count` cameras along a smooth path (about 2.7 m long, at about 1.45 m
// height, near the x = 0.5..1.5 side of the room) looking mostly at the boxes
// (around (4, 2.5, 0.5)). focal ratio 0.8; `seed` varies the path smoothly.
std::vector<PinholeCamera> makeSmoothTrajectory(int count, int width, int height, uint32_t seed);

// The camera of that path at path parameter `s` (makeSmoothTrajectory's view
// i is s = i / (count - 1), bit for bit); any s, for poses between and
// beyond the views.
PinholeCamera smoothTrajectoryCamera(double s, int width, int height, uint32_t seed);

}  // namespace amhmvs
