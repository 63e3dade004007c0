// COLMAP sparse models (text or binary) as multi-view scenes, with per-view
// depth ranges and ranked source views derived from the sparse points.
#pragma once

#include <string>

#include "amhmvs_mapping/io/scene.h"

namespace amhmvs {

struct ColmapOptions {
  enum class Format { kAuto, kBinary, kText };
  // kAuto takes the binary model when both are present (full precision).
  Format format = Format::kAuto;

  // Depth range of a view: these quantiles (fractions) of the z-depths of the
  // points it observes, then depth_min * min_scale and depth_max * max_scale.
  double depth_low_percentile = 0.01;
  double depth_high_percentile = 0.99;
  double depth_min_scale = 0.8;
  double depth_max_scale = 1.2;
  // Views observing fewer points (in front of the camera) are an error.
  int min_points = 10;

  // Source score of view j for reference i: the sum over their shared points
  // of exp(-(theta - theta0)^2 / (2 sigma^2)), theta the triangulation angle,
  // sigma = sigma1 for theta <= theta0, else sigma2 (MVSNet's view selection).
  double theta0_deg = 5.0;
  double sigma1_deg = 1.0;
  double sigma2_deg = 10.0;
  // At most this many sources per view, best first, each with score > 0.
  int max_sources = 10;
};

// Reads the model in `sparse_dir` (cameras, images, points3D as .bin or .txt);
// image paths are `image_dir/<name>`. Views are sorted by COLMAP image id and
// use it as view id. Only PINHOLE and SIMPLE_PINHOLE cameras are accepted (run
// `colmap image_undistorter` first for others). Throws InputError naming the
// file (and line for text) and the problem, a missing image file, an image
// whose header size differs from its camera, or a view with too few points.
Scene readColmapModel(const std::string& sparse_dir, const std::string& image_dir,
                      const ColmapOptions& options = {});

// Reads a workspace as written by `colmap image_undistorter`: the model in
// `dir/sparse/` (or `dir/sparse/0/`), images in `dir/images/`.
Scene readColmapWorkspace(const std::string& dir, const ColmapOptions& options = {});

}  // namespace amhmvs
