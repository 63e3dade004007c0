#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "amhmvs_mapping/mvs/view_geometry.h"

#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/coarse_to_fine.h"
#include "amhmvs_mapping/mvs/planar_prior.h"
#include "backends.h"

namespace amhmvs {

const char* backendName(Backend backend) {
  switch (backend) {
    case Backend::kAuto: return "auto";
    case Backend::kCuda: return "cuda";
    default: return "cpu";
  }
}

Backend parseBackend(const std::string& name) {
  if (name == "auto") return Backend::kAuto;
  if (name == "cuda") return Backend::kCuda;
  if (name == "cpu") return Backend::kCpu;
  throw InputError("backend '" + name + "' is not one of auto, cuda, cpu");
}

std::string DepthProblem::validate() const {
  std::ostringstream why;
  auto check_view = [&](const std::string& label, const PinholeCamera& camera,
                        const ImageViewU8& image) {
    const std::string camera_problem = camera.validate();
    if (!camera_problem.empty()) {
      why << label << ": " << camera_problem << "\n";
    } else if (image.channels != 1) {
      why << label << ": image must be 8-bit grey (1 channel), has " << image.channels << "\n";
    } else if (!image.sameSize(camera.width, camera.height)) {
      why << label << ": image is " << image.width << "x" << image.height
          << " but its camera is " << camera.width << "x" << camera.height << "\n";
    } else if (image.data == nullptr) {
      why << label << ": the image view has no pixels\n";
    }
  };
  check_view("reference view", reference_camera, reference_image);
  if (source_cameras.size() != source_images.size()) {
    why << source_cameras.size() << " source cameras but " << source_images.size()
        << " source images\n";
  }
  if (!source_keys.empty() && source_keys.size() != source_cameras.size()) {
    why << source_keys.size() << " source keys for " << source_cameras.size()
        << " source views (give none or one per source)\n";
  }
  if (source_cameras.empty()) why << "no source views: at least 1 is needed\n";
  const auto check_key = [&](const std::string& label, int64_t key) {
    if (key != kNoImageKey && key <= mvs::kScaledImageKeyBase) {
      why << label << ": image key " << key << " is reserved (keys must be above " << mvs::kScaledImageKeyBase
          << ")\n";
    }
  };
  check_key("reference view", reference_key);
  for (size_t i = 0; i < source_keys.size(); ++i) check_key("source view " + std::to_string(i), source_keys[i]);
  if (source_cameras.size() > static_cast<size_t>(kMaxSourceViews)) {
    why << source_cameras.size() << " source views; at most " << kMaxSourceViews
        << " are supported\n";
  }
  for (size_t i = 0; i < std::min(source_cameras.size(), source_images.size()); ++i) {
    check_view("source view " + std::to_string(i), source_cameras[i], source_images[i]);
    if ((source_cameras[i].center() - reference_camera.center()).norm() <= 0.0) {
      why << "source view " << i << ": same camera centre as the reference (no baseline)\n";
    }
  }
  if (!source_depths.empty() && source_depths.size() != source_cameras.size()) {
    why << source_depths.size() << " source depth maps for " << source_cameras.size()
        << " source views (give none or one per source)\n";
  }
  for (size_t i = 0; i < std::min(source_depths.size(), source_cameras.size()); ++i) {
    const ImageViewF& d = source_depths[i];
    if (d.data != nullptr && (d.channels != 1 || !d.sameSize(source_cameras[i].width, source_cameras[i].height))) {
      why << "source depth map " << i << ": " << d.width << "x" << d.height << "x" << d.channels
          << " but its camera is " << source_cameras[i].width << "x" << source_cameras[i].height
          << " (1 channel)\n";
    }
  }
  // A plane map (depth and normals at the reference size), named by `label`.
  const auto check_plane_map = [&](const char* label, const ImageViewF& depth, const ImageViewF& normal) {
    if ((depth.data != nullptr) != (normal.data != nullptr)) {
      why << label << " depth and " << label << " normal map must be given together\n";
    } else if (depth.data != nullptr &&
               (depth.channels != 1 || normal.channels != 3 ||
                !depth.sameSize(reference_camera.width, reference_camera.height) ||
                !normal.sameSize(reference_camera.width, reference_camera.height))) {
      why << label << " depth (" << depth.width << "x" << depth.height << "x" << depth.channels << ") and normal ("
          << normal.width << "x" << normal.height << "x" << normal.channels
          << ") maps must be 1 and 3 channels at the reference size " << reference_camera.width << "x"
          << reference_camera.height << "\n";
    }
  };
  check_plane_map("prior", prior_depth, prior_normal);
  check_plane_map("planar prior", planar_prior_depth, planar_prior_normal);
  const bool has_prior_depth = prior_depth.data != nullptr;
  if (coarser) {
    const CoarserScale& c = *coarser;
    if (has_prior_depth) why << "a coarser scale's planes and a prior depth map cannot both start an estimate\n";
    if (c.image.channels != 1 || !c.image.sameSize(c.camera.width, c.camera.height) || c.depth.channels != 1 ||
        !c.depth.sameSize(c.camera.width, c.camera.height) || c.normal.channels != 3 ||
        !c.normal.sameSize(c.camera.width, c.camera.height) || !c.image.data || !c.depth.data || !c.normal.data) {
      why << "coarser scale: image, depth and normal maps must be 1, 1 and 3 channels at its camera's size "
          << c.camera.width << "x" << c.camera.height << "\n";
    }
  }
  if (prior_iterations < 0 || prior_iterations > 100) {
    why << "prior_iterations " << prior_iterations << " must be in 0..100 (0: the estimator's schedule)\n";
  }
  if (!(std::isfinite(depth_min) && std::isfinite(depth_max) && depth_min > 0 &&
        depth_max > depth_min)) {
    why << "depth range [" << depth_min << ", " << depth_max
        << "] is empty, inverted, non-positive or not finite\n";
  }
  return why.str();
}

void OwnedDepthProblem::setReference(const PinholeCamera& camera, ImageU8 image) {
  reference_image_ = std::move(image);
  problem.reference_camera = camera;
  problem.reference_image = reference_image_;
}

void OwnedDepthProblem::addSource(const PinholeCamera& camera, ImageU8 image) {
  // Growing source_images_ moves the Image objects, not their pixel buffers:
  // the views taken so far stay valid.
  source_images_.push_back(std::move(image));
  problem.source_cameras.push_back(camera);
  problem.source_images.push_back(source_images_.back());
}

std::string EstimatorResources::validate() const {
  // Any budget is valid: 0 keeps nothing between estimates.
  return "";
}

namespace mvs {

void CudaStateDeleter::operator()(CudaState* state) const { destroyCudaState(state); }

std::vector<float> concatenateSourceDepths(const DepthProblem& problem, PatchMatchParams* P) {
  std::vector<float> all;
  for (size_t j = 0; j < problem.source_depths.size(); ++j) {
    const ImageViewF& depth = problem.source_depths[j];
    if (!depth.data) continue;  // that source has no depth map: full error
    P->back[j].depth_offset = static_cast<long long>(all.size());
    all.insert(all.end(), depth.data, depth.data + depth.pixelCount());
  }
  return all;
}

PatchMatchParams makePatchMatchParams(const PatchMatchOptions& o, const DepthProblem& problem) {
  PatchMatchParams p{};
  const PinholeCamera& ref = problem.reference_camera;
  p.width = ref.width;
  p.height = ref.height;
  p.num_sources = static_cast<int>(problem.source_cameras.size());
  p.K = intrinsicsOf(ref);
  p.depth_min = static_cast<float>(problem.depth_min);
  p.depth_max = static_cast<float>(problem.depth_max);
  p.min_normal_cos = std::cos(o.max_normal_angle_deg * static_cast<float>(M_PI) / 180.0f);
  p.seed = o.random_seed;
  p.heuristic_view_selection = o.view_selection == ViewSelectionScheme::kHeuristicTopK;
  p.bisection_only_iterations = o.bisection_only_iterations;
  p.bisection_steps = o.bisection_steps;
  p.perturbation = o.perturbation;
  p.cost = {o.window_radius, o.window_step, o.sigma_color, o.sigma_spatial};
  p.selection = {o.tau_mc_init, o.tau_alpha, o.tau_up, o.beta, o.n1, o.n2, o.top_k,
                 o.best_view_boost, o.previous_selection_weight, o.heuristic_k};
  p.pattern = makePropagationPattern(o.propagation);
  for (int j = 0; j < p.num_sources; ++j) {
    Eigen::Matrix3d A;
    // layer: the CPU sampler's index; the CUDA backend puts its pool slot here.
    p.sources[j] = sourceGeometry(ref, problem.source_cameras[j], j, &A);
    const Eigen::Matrix3d A_inv = A.inverse();
    for (int i = 0; i < 9; ++i) p.back[j].A_inv.m[i] = static_cast<float>(A_inv(i / 3, i % 3));
    p.back[j].depth_offset = -1;  // set by the backend with the depth buffer
  }
  p.first_iteration = o.first_iteration;
  p.geometric = {!problem.source_depths.empty(), o.geometric_weight, o.geometric_max_error};
  p.source_depths = nullptr;
  p.prior_depth = p.prior_normal = nullptr;
  p.planar = PlanarPriorTerm();  // the backend points it at the problem's maps
  p.planar.weight = o.planar_prior_weight;
  p.planar.inv_depth_sigma = 1.0f / o.planar_prior_depth_sigma;
  const float normal_sigma = o.planar_prior_normal_sigma_deg * static_cast<float>(M_PI) / 180.0f;
  p.planar.inv_normal_sigma_squared = 1.0f / (normal_sigma * normal_sigma);
  p.unscored_cost = kMaxCost + (p.geometric.enabled ? o.geometric_weight * o.geometric_max_error : 0.0f);
  return p;
}

}  // namespace mvs

namespace {

// The planar prior's second pass (mvs/planar_prior.h): local refinement at
// full scale from the first pass's planes, with the prior made from them.
template <class Run>
DepthMap secondPassWithPlanarPrior(const PatchMatchOptions& options, const DepthProblem& problem,
                                   const DepthMap& first, const Run& run) {
  const mvs::PlaneMap prior =
      mvs::planarPrior(problem.reference_image, first.depth, first.normal, first.cost, problem.reference_camera, options);
  DepthProblem second = problem;
  second.coarser.reset();
  second.prior_depth = first.depth;
  second.prior_normal = first.normal;
  second.planar_prior_depth = prior.depth;
  second.planar_prior_normal = prior.normal;
  PatchMatchOptions refinement = options;
  refinement.num_iterations = options.planar_prior_iterations;
  refinement.first_iteration = options.bisection_only_iterations;
  refinement.multiscale_levels = 1;
  DepthMap out = run(refinement, second, mvs::CudaOutputUse::kResult);
  out.milliseconds += first.milliseconds;
  out.compute_milliseconds += first.compute_milliseconds;
  return out;
}

}  // namespace

DepthEstimator::DepthEstimator(const PatchMatchOptions& options, Backend backend,
                               const EstimatorResources& resources)
    : options_(options), backend_(backend), resources_(resources) {
  const std::string problems = options.validate() + resources.validate();
  if (!problems.empty()) throw InputError("invalid estimator options:\n" + problems);
  std::string description;
  const bool cuda = mvs::cudaDeviceUsable(&description);
  if (backend_ == Backend::kAuto) backend_ = cuda ? Backend::kCuda : Backend::kCpu;
  if (backend_ == Backend::kCuda && !cuda) {
    throw BackendError("CUDA backend requested but unavailable: " + description);
  }
  if (backend_ == Backend::kCuda) cuda_.reset(mvs::createCudaState(resources_));
}

DepthEstimator::~DepthEstimator() = default;

DepthMap DepthEstimator::estimate(const DepthProblem& problem) const {
  const std::string problems = problem.validate();
  if (!problems.empty()) throw InputError("invalid depth problem:\n" + problems);
  PatchMatchOptions options = options_;
  if (problem.prior_depth.data && problem.prior_iterations > 0) {
    options.num_iterations = problem.prior_iterations;
    options.first_iteration = options.bisection_only_iterations;
  }
  const bool second_pass = options_.planar_prior;
  // Every scale of a coarse-to-fine estimate runs on this estimator's backend.
  // A coarser scale's maps only start the next scale, and a first pass's the
  // second: neither may take the place of the last result (CUDA), which may
  // still be fused.
  const auto run = [this, &problem](const PatchMatchOptions& options, const DepthProblem& scale_problem,
                                    mvs::CudaOutputUse full_scale_use) {
    const mvs::PatchMatchParams params = mvs::makePatchMatchParams(options, scale_problem);
    if (backend_ == Backend::kCuda) {
      const bool full_scale = scale_problem.reference_camera.width == problem.reference_camera.width &&
                              scale_problem.reference_camera.height == problem.reference_camera.height;
      const std::lock_guard<std::mutex> lock(mutex_);
      return mvs::estimateOnCuda(*cuda_, options, params, scale_problem,
                                 full_scale ? full_scale_use : mvs::CudaOutputUse::kIntermediate);
    }
    return mvs::estimateOnCpu(options, params, scale_problem);
  };
  DepthMap first = mvs::estimateCoarseToFine(
      options, problem,
      [&](const PatchMatchOptions& options, const DepthProblem& scale_problem) {
        return run(options, scale_problem,
                   second_pass ? mvs::CudaOutputUse::kFirstPass : mvs::CudaOutputUse::kResult);
      },
      &scaled_images_);
  if (!second_pass) return first;
  return secondPassWithPlanarPrior(options, problem, first, run);
}

void DepthEstimator::forget(int64_t key) {
  const std::vector<int64_t> scaled_keys = scaled_images_.forget(key);
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!cuda_) return;
  mvs::forgetOnCuda(*cuda_, key);
  for (int64_t scaled_key : scaled_keys) mvs::forgetOnCuda(*cuda_, scaled_key);
}

void DepthEstimator::forgetAll() {
  scaled_images_.forgetAll();
  const std::lock_guard<std::mutex> lock(mutex_);
  if (cuda_) mvs::forgetAllOnCuda(*cuda_);
}

DeviceCacheStats DepthEstimator::deviceCacheStats() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return cuda_ ? mvs::cudaCacheStats(*cuda_) : DeviceCacheStats();
}

DeviceDepthMap DepthEstimator::lastDeviceOutputs() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return cuda_ ? mvs::cudaLastOutputs(*cuda_) : DeviceDepthMap();
}

bool cudaBackendAvailable(std::string* description) { return mvs::cudaDeviceUsable(description); }

Backend resolvedBackend(Backend requested, std::string* why_not_gpu) {
  if (requested != Backend::kAuto) return requested;
  std::string description;
  if (cudaBackendAvailable(&description)) return Backend::kCuda;
  if (why_not_gpu) *why_not_gpu = description;
  return Backend::kCpu;
}

}  // namespace amhmvs
