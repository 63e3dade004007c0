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

namespace {

// Which views a problem uses and its depth range, before any image is read.
struct ProblemPlan {
  int reference_index = -1;
  std::vector<int> source_indices;  // into scene.views, best first
  double depth_min = 0, depth_max = 0;
};

ProblemPlan planProblem(const Scene& scene, int reference_id, const ProblemOptions& options) {
  const std::string option_problems = options.validate();
  if (!option_problems.empty()) throw InputError("invalid problem options:\n" + option_problems);
  ProblemPlan plan;
  plan.reference_index = scene.indexOf(reference_id);
  if (plan.reference_index < 0) throw InputError("reference view " + std::to_string(reference_id) + " does not exist");
  const SceneView& ref = scene.views[plan.reference_index];
  const auto sources = scene.sources.find(reference_id);
  if (sources == scene.sources.end() || sources->second.empty()) {
    throw InputError("view " + std::to_string(reference_id) + " has no source views");
  }
  for (const SourceCandidate& candidate : sources->second) {
    if (static_cast<int>(plan.source_indices.size()) >= options.max_sources) break;
    const int index = scene.indexOf(candidate.view_id);
    if (index < 0) {
      throw InputError("view " + std::to_string(reference_id) + ": source view " +
                       std::to_string(candidate.view_id) + " does not exist");
    }
    plan.source_indices.push_back(index);
  }
  if (options.depth_min > 0) {
    plan.depth_min = options.depth_min;
    plan.depth_max = options.depth_max;
  } else {
    plan.depth_min = ref.depth_min;
    plan.depth_max = ref.depth_max;
    if (!(std::isfinite(ref.depth_min) && std::isfinite(ref.depth_max) && ref.depth_min > 0 &&
          ref.depth_max > ref.depth_min)) {
      std::ostringstream why;
      why << "view " << reference_id << ": depth range [" << ref.depth_min << ", " << ref.depth_max
          << "] is missing, empty or inverted; give --depth_min and --depth_max";
      throw InputError(why.str());
    }
  }
  return plan;
}

}  // namespace

OwnedDepthProblem makeDepthProblem(const Scene& scene, int reference_id, const ProblemOptions& options) {
  const ProblemPlan plan = planProblem(scene, reference_id, options);
  OwnedDepthProblem owned;
  PinholeCamera camera;
  ImageU8 image;
  loadView(scene.views[plan.reference_index], options, &camera, &image);
  owned.setReference(camera, std::move(image));
  for (int index : plan.source_indices) {
    loadView(scene.views[index], options, &camera, &image);
    owned.addSource(camera, std::move(image));
  }
  owned.problem.depth_min = plan.depth_min;
  owned.problem.depth_max = plan.depth_max;
  return owned;
}

SceneImageCache::SceneImageCache(const Scene& scene, const ProblemOptions& options, size_t max_bytes)
    : scene_(scene), options_(options), max_bytes_(max_bytes) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("invalid problem options:\n" + problems);
}

const SceneImageCache::Entry& SceneImageCache::view(int index) {
  const int id = scene_.views[index].id;
  auto found = entries_.find(id);
  if (found == entries_.end()) {
    Entry entry;
    loadView(scene_.views[index], options_, &entry.camera, &entry.image);
    bytes_ += entry.image.data.size();
    found = entries_.emplace(id, std::move(entry)).first;
  }
  found->second.last_problem = problems_;
  return found->second;
}

void SceneImageCache::dropOldImages() {
  while (bytes_ > max_bytes_) {
    auto oldest = entries_.end();
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->second.last_problem != problems_ &&
          (oldest == entries_.end() || it->second.last_problem < oldest->second.last_problem)) {
        oldest = it;
      }
    }
    if (oldest == entries_.end()) return;  // all used by the current problem
    const int id = oldest->first;
    bytes_ -= oldest->second.image.data.size();
    entries_.erase(oldest);
    if (on_drop_) on_drop_(id);
  }
}

DepthProblem SceneImageCache::makeProblem(int reference_id) {
  const ProblemPlan plan = planProblem(scene_, reference_id, options_);
  ++problems_;
  DepthProblem problem;
  const Entry& reference = view(plan.reference_index);
  problem.reference_camera = reference.camera;
  problem.reference_image = reference.image;
  problem.reference_key = reference_id;
  for (int index : plan.source_indices) {
    const Entry& source = view(index);
    problem.source_cameras.push_back(source.camera);
    problem.source_images.push_back(source.image);
    problem.source_keys.push_back(scene_.views[index].id);
  }
  problem.depth_min = plan.depth_min;
  problem.depth_max = plan.depth_max;
  // Only now: the images of this problem are marked as in use.
  dropOldImages();
  return problem;
}

}  // namespace amhmvs
