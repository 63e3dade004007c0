// Builds estimator problems from a Scene read from disk: loads and scales the
// images, picks the source views and the depth range of a reference view.
#pragma once

#include <string>

#include "amhmvs_mapping/io/scene.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct ProblemOptions {
  int max_sources = 10;       // first N of the ranked source list
  int max_image_size = 0;     // longest image side after scaling; 0 = no limit
  double scale = 1.0;         // image scale factor applied before max_image_size
  double depth_min = 0;       // > 0: overrides the view's depth range
  double depth_max = 0;

  std::string validate() const;
};

// Problem for reference view `reference_id`; throws InputError naming the
// view and the problem (unknown id, no sources, no depth range, unreadable
// image, image that does not match its camera). The images are owned by the
// returned object (its `problem` borrows them).
OwnedDepthProblem makeDepthProblem(const Scene& scene, int reference_id, const ProblemOptions& options);

// Image size after applying scale and max_image_size to (width, height).
void scaledSize(int width, int height, const ProblemOptions& options, int* out_width,
                int* out_height);

}  // namespace amhmvs
