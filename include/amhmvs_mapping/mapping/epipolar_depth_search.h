// Depths of a few target pixels found by matching image patches along their
// epipolar lines in one other view: the scene depth of a keyframe before any
// depth map or SLAM point exists (the first pair of a run).
//
// A grid of textured target patches (grid_size x grid_size, radius
// patch_radius) is compared by normalised cross-correlation with the source
// image along each pixel's epipolar line, from min_depth to infinity sampled
// evenly in inverse depth (about two samples per source pixel). A pixel's
// depth counts when its best correlation reaches min_correlation and no other
// position more than 2 px away along the line comes within uniqueness_margin
// of it (repetitive texture is left out). Patches are compared without
// warping: fine for the median of a scene, not for dense depth.
#pragma once

#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

struct EpipolarSearchOptions {
  int grid_size = 16;               // target pixels per image side
  int patch_radius = 4;             // 9x9 patches
  double min_texture = 4.0;         // grey-level standard deviation a patch needs
  double min_depth = 0.1;           // metres: nearest depth searched
  int max_steps = 2048;             // samples along one epipolar line, at most
  double min_correlation = 0.85;    // NCC in [-1, 1]
  double uniqueness_margin = 0.05;  // NCC the runner-up must stay below the best

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// Z-depths (target camera) of the target pixels matched in the source; empty
// when none matches. Images are 8-bit grey of their camera's size. Throws
// InputError for invalid options or images that do not match their cameras.
std::vector<double> matchDepthsAlongEpipolarLines(const PinholeCamera& target_camera,
                                                  const ImageU8& target_image,
                                                  const PinholeCamera& source_camera,
                                                  const ImageU8& source_image,
                                                  const EpipolarSearchOptions& options = EpipolarSearchOptions());

}  // namespace amhmvs
