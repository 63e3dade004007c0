#include "amhmvs_mapping/mvs/problem_builder.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"

namespace amhmvs {

std::string ProblemOptions::validate() const {
  std::ostringstream why;
  if (max_sources < 1 || max_sources > kMaxSourceViews) {
    why << "max_sources must be in 1.." << kMaxSourceViews << " (got " << max_sources << ")\n";
  }
  if (max_image_size < 0) why << "max_image_size must be >= 0\n";
  if (!(std::isfinite(scale) && scale > 0 && scale <= 1)) why << "scale must be in (0, 1]\n";
  if ((depth_min > 0 || depth_max > 0) &&
      !(std::isfinite(depth_min) && std::isfinite(depth_max) && depth_min > 0 && depth_max > depth_min)) {
    why << "depth range override [" << depth_min << ", " << depth_max << "] is empty or invalid\n";
  }
  return why.str();
}

void scaledSize(int width, int height, const ProblemOptions& options, int* out_width,
                int* out_height) {
  double s = options.scale;
  const int longest = std::max(width, height);
  if (options.max_image_size > 0 && longest * s > options.max_image_size) {
    s = static_cast<double>(options.max_image_size) / longest;
  }
  *out_width = std::max(1, static_cast<int>(std::lround(width * s)));
  *out_height = std::max(1, static_cast<int>(std::lround(height * s)));
}

namespace {

// Grey image of a view at the processed resolution, with its scaled camera.
void loadView(const SceneView& view, const ProblemOptions& options, PinholeCamera* camera,
              ImageU8* image) {
  ImageU8 full = toGray(readImage(view.image_path));
  if (!full.sameSize(view.camera.width, view.camera.height)) {
    std::ostringstream why;
    why << view.image_path << ": image is " << full.width << "x" << full.height
        << " but its camera says " << view.camera.width << "x" << view.camera.height;
    throw InputError(why.str());
  }
  int width, height;
  scaledSize(full.width, full.height, options, &width, &height);
  *camera = view.camera.resized(width, height);
  *image = (width == full.width && height == full.height) ? std::move(full)
                                                          : resizeArea(full, width, height);
}

}  // namespace

OwnedDepthProblem makeDepthProblem(const Scene& scene, int reference_id, const ProblemOptions& options) {
  const std::string option_problems = options.validate();
  if (!option_problems.empty()) throw InputError("invalid problem options:\n" + option_problems);
  const int ref_index = scene.indexOf(reference_id);
  if (ref_index < 0) throw InputError("reference view " + std::to_string(reference_id) + " does not exist");
  const SceneView& ref = scene.views[ref_index];
  const auto sources = scene.sources.find(reference_id);
  if (sources == scene.sources.end() || sources->second.empty()) {
    throw InputError("view " + std::to_string(reference_id) + " has no source views");
  }

  OwnedDepthProblem owned;
  DepthProblem& problem = owned.problem;
  PinholeCamera camera;
  ImageU8 image;
  loadView(ref, options, &camera, &image);
  owned.setReference(camera, std::move(image));
  for (const SourceCandidate& candidate : sources->second) {
    if (static_cast<int>(problem.source_cameras.size()) >= options.max_sources) break;
    const int index = scene.indexOf(candidate.view_id);
    if (index < 0) {
      throw InputError("view " + std::to_string(reference_id) + ": source view " +
                       std::to_string(candidate.view_id) + " does not exist");
    }
    loadView(scene.views[index], options, &camera, &image);
    owned.addSource(camera, std::move(image));
  }
  if (options.depth_min > 0) {
    problem.depth_min = options.depth_min;
    problem.depth_max = options.depth_max;
  } else {
    problem.depth_min = ref.depth_min;
    problem.depth_max = ref.depth_max;
    if (!(std::isfinite(ref.depth_min) && std::isfinite(ref.depth_max) && ref.depth_min > 0 &&
          ref.depth_max > ref.depth_min)) {
      std::ostringstream why;
      why << "view " << reference_id << ": depth range [" << ref.depth_min << ", " << ref.depth_max
          << "] is missing, empty or inverted; give --depth_min and --depth_max";
      throw InputError(why.str());
    }
  }
  return owned;
}

}  // namespace amhmvs
