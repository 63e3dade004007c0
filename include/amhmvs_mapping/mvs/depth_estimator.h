// The AMHMVS depth estimator: one reference view, its source views and a
// depth range in; depth, normal and cost maps of the reference view out.
//
//   DepthEstimator estimator(options, Backend::kAuto);
//   DepthMap map = estimator.estimate(problem);
//
// Backends: CUDA (when built with nvcc and a GPU is present) and CPU
// (OpenMP). Both run the same per-pixel code (patchmatch_pixel.h) and give
// the same result up to float rounding; each is deterministic for a seed.
#pragma once

#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs {

enum class Backend { kAuto, kCuda, kCpu };
const char* backendName(Backend backend);
// Parses "auto", "cuda" or "cpu"; throws InputError otherwise.
Backend parseBackend(const std::string& name);

struct DepthProblem {
  PinholeCamera reference_camera;
  ImageU8 reference_image;  // 8-bit grey, size of reference_camera
  std::vector<PinholeCamera> source_cameras;
  std::vector<ImageU8> source_images;  // 8-bit grey, sizes of their cameras
  double depth_min = 0, depth_max = 0;  // z-depth range of the reference view, metres

  // Empty when the problem can be solved; otherwise what is wrong (which view,
  // which value).
  std::string validate() const;
};

struct DepthMap {
  ImageF depth;   // z-depth in metres; NaN where nothing could be scored
  ImageF normal;  // 3 channels, unit normal in the reference camera frame
  ImageF cost;    // aggregated matching cost in [0, 2]
  Backend backend = Backend::kCpu;
  double milliseconds = 0;  // estimator time (upload to download)
  // CUDA: the part of `milliseconds` after the images are in device memory
  // (kernels and download of depth, normal and cost); equal to it on the CPU.
  double compute_milliseconds = 0;
  size_t gpu_memory_bytes = 0;  // device memory taken by this estimate (CUDA)
};

class DepthEstimator {
 public:
  // Throws InputError when the options are invalid. kAuto picks CUDA when a
  // GPU is usable and the CPU otherwise; kCuda throws BackendError without one.
  explicit DepthEstimator(const PatchMatchOptions& options, Backend backend = Backend::kAuto);

  // Throws InputError for an invalid problem, BackendError when the backend
  // fails (e.g. GPU out of memory).
  DepthMap estimate(const DepthProblem& problem) const;

  Backend backend() const { return backend_; }
  const PatchMatchOptions& options() const { return options_; }

 private:
  PatchMatchOptions options_;
  Backend backend_;
};

// Whether this build has the CUDA backend and a usable GPU; `description`
// names the GPU or says why none is usable.
bool cudaBackendAvailable(std::string* description);

}  // namespace amhmvs
