// The AMHMVS depth estimator: one reference view, its source views and a
// depth range in; depth, normal and cost maps of the reference view out.
//
//   DepthEstimator estimator(options, Backend::kAuto);
//   DepthMap map = estimator.estimate(problem);
//
// Backends: CUDA (when built with nvcc and a GPU is present) and CPU
// (OpenMP). Both run the same per-pixel code (patchmatch_pixel.h) and give
// the same result up to float rounding; each is deterministic for a seed.
//
// A problem borrows its images (ImageView). Images that take part in many
// estimates (keyframes of an online map) may carry a key: the CUDA backend
// then uploads each keyed image once and keeps it in device memory, within a
// byte budget (EstimatorResources), until the owner calls forget(key) or the
// budget needs the room (least recently used first).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"
#include "amhmvs_mapping/mvs/scaled_image_cache.h"

namespace amhmvs {

enum class Backend { kAuto, kCuda, kCpu };
const char* backendName(Backend backend);
// Parses "auto", "cuda" or "cpu"; throws InputError otherwise.
Backend parseBackend(const std::string& name);

// "This image has no key": uploaded for this estimate only.
constexpr int64_t kNoImageKey = -1;

struct DepthProblem {
  PinholeCamera reference_camera;
  ImageViewU8 reference_image;  // 8-bit grey, size of reference_camera
  std::vector<PinholeCamera> source_cameras;
  std::vector<ImageViewU8> source_images;  // 8-bit grey, sizes of their cameras
  double depth_min = 0, depth_max = 0;  // z-depth range of the reference view, metres
  // Optional identities of the images for backends that keep images resident
  // (CUDA): one key means the same pixels until the owner calls
  // DepthEstimator::forget(key). source_keys is empty or one per source;
  // kNoImageKey anywhere means "not kept".
  int64_t reference_key = kNoImageKey;
  std::vector<int64_t> source_keys;
  // Geometric consistency (optional): empty, or one z-depth map per source at
  // its camera's size (an empty view: that source has none). Adds the
  // reprojection term of geometric_consistency.h to every matching cost.
  std::vector<ImageViewF> source_depths;
  // Optional start (empty, or both at the reference camera's size): depth
  // (1 channel) and unit normals (3 channels, camera frame), e.g. this view's
  // photometric result; random planes where they are invalid.
  ImageViewF prior_depth, prior_normal;
  // With a prior: 0 runs the estimator's schedule from it; N > 0 runs N
  // iterations of local refinement instead (numbered from the estimator's
  // bisection_only_iterations, as the geometric pass), for a start that is
  // near the answer already. With several scales (multiscale), the prior
  // starts the coarsest one.
  int prior_iterations = 0;
  // Optional planar prior (empty, or both at the reference camera's size):
  // per pixel a plane's depth (NaN: none) and unit normal whose term
  // (planar_prior_pixel.h) is added to every hypothesis's cost. With
  // PatchMatchOptions::planar_prior the estimator makes one from its first
  // pass and runs a second; a caller may give its own (e.g. from a map).
  ImageViewF planar_prior_depth, planar_prior_normal;
  // Coarse-to-fine (mvs/coarse_to_fine.h): the estimate of this view at the
  // next coarser scale, whose planes, carried to this scale by
  // resamplePlanes (mvs/plane_map.h), start this estimate (instead of
  // prior_depth / prior_normal, which must then be empty). The backend
  // carries them: the CUDA backend on the device, from the coarser estimate
  // it has just made.
  struct CoarserScale {
    PinholeCamera camera;
    ImageViewU8 image;          // grey, the camera's size
    ImageViewF depth, normal;   // 1 and 3 channels, the camera's size
  };
  std::optional<CoarserScale> coarser;

  // Empty when the problem can be solved; otherwise what is wrong (which view,
  // which value).
  std::string validate() const;
};

// A DepthProblem with the images it borrows, for problems made from files or
// synthetic scenes. Not copyable; moving keeps the views valid (the pixel
// buffers move with their owner).
class OwnedDepthProblem {
 public:
  OwnedDepthProblem() = default;
  OwnedDepthProblem(OwnedDepthProblem&&) = default;
  OwnedDepthProblem& operator=(OwnedDepthProblem&&) = default;
  OwnedDepthProblem(const OwnedDepthProblem&) = delete;
  OwnedDepthProblem& operator=(const OwnedDepthProblem&) = delete;

  // Store the image and borrow it into `problem`.
  void setReference(const PinholeCamera& camera, ImageU8 image);
  void addSource(const PinholeCamera& camera, ImageU8 image);

  DepthProblem problem;  // depth range and keys are the caller's to set

 private:
  ImageU8 reference_image_;
  std::vector<ImageU8> source_images_;
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
  // CUDA: device memory the estimator holds after this estimate (image pool
  // and work buffers, both reused by the next estimate).
  size_t gpu_memory_bytes = 0;
};

// A depth map's depth, normal and cost in device memory (CUDA), so that a
// consumer on the same GPU (DepthMapFuser) copies them there instead of
// uploading the host copy. `host_*` name the host images those buffers
// equal (the DepthMap an estimate returned): a consumer uses the device
// copy only for a view that borrows exactly these images.
struct DeviceDepthMap {
  const float* host_depth = nullptr;
  const float* host_normal = nullptr;
  const float* host_cost = nullptr;
  const float* depth = nullptr;   // device, width x height
  const float* normal = nullptr;  // device, 3 x width x height
  const float* cost = nullptr;    // device, width x height
  int width = 0, height = 0;
  bool empty() const { return depth == nullptr; }
};

// Machine resources of an estimator (not of the algorithm: results do not
// depend on them).
struct EstimatorResources {
  // Device memory for keyed images kept between estimates (CUDA), at most as
  // many images as the GPU has texture layers (2048 on an H100). One
  // estimate's own images are always held, even when they need more.
  // Coarse-to-fine's coarser copies, once used, get a fifth of it.
  size_t device_image_budget_bytes = size_t(256) << 20;

  std::string validate() const;
};

// What the CUDA backend's image pool did since construction (zeros on the CPU).
struct DeviceCacheStats {
  uint64_t uploads = 0;          // keyed images copied to the device
  uint64_t hits = 0;             // keyed images found resident
  uint64_t evictions = 0;        // keyed images dropped for room (LRU)
  uint64_t forgotten = 0;        // keyed images dropped by forget()/forgetAll()
  uint64_t unkeyed_uploads = 0;  // images without a key (uploaded per estimate)
  size_t resident_images = 0;    // keyed images resident now
  size_t resident_bytes = 0;     // their slots' bytes
  size_t budget_bytes = 0;
  size_t slot_bytes = 0;         // one slot: the largest image seen
  size_t pool_bytes = 0;         // the whole image pool (all slots)
  size_t work_bytes = 0;         // pooled per-pixel buffers (grow only)

  // Another image pool's numbers added (slot size and budget stay these).
  void add(const DeviceCacheStats& other) {
    uploads += other.uploads;
    hits += other.hits;
    evictions += other.evictions;
    forgotten += other.forgotten;
    unkeyed_uploads += other.unkeyed_uploads;
    resident_images += other.resident_images;
    resident_bytes += other.resident_bytes;
    pool_bytes += other.pool_bytes;
    work_bytes += other.work_bytes;
  }
};

namespace mvs {
class CudaState;
struct CudaStateDeleter {
  void operator()(CudaState* state) const;
};
}  // namespace mvs

class DepthEstimator {
 public:
  // Throws InputError when the options or resources are invalid. kAuto picks
  // CUDA when a GPU is usable and the CPU otherwise; kCuda throws
  // BackendError without one.
  explicit DepthEstimator(const PatchMatchOptions& options, Backend backend = Backend::kAuto,
                          const EstimatorResources& resources = EstimatorResources());
  ~DepthEstimator();
  DepthEstimator(const DepthEstimator&) = delete;
  DepthEstimator& operator=(const DepthEstimator&) = delete;

  // Throws InputError for an invalid problem (or a key whose image changed
  // size without forget()), BackendError when the backend fails (e.g. GPU out
  // of memory). Calls on one estimator are serialised (one CUDA stream).
  DepthMap estimate(const DepthProblem& problem) const;

  // The owner of keyed images: the pixels of `key` changed or are gone.
  void forget(int64_t key);
  void forgetAll();
  DeviceCacheStats deviceCacheStats() const;
  // CUDA: the last estimate's outputs on the device (empty on the CPU,
  // before the first estimate and after one that failed). Valid during the
  // next estimate too, until the one after it has begun: estimates write
  // two sets of output buffers in turn (a failed one does not count), so
  // that a consumer can read a keyframe's maps while the next is estimated.
  DeviceDepthMap lastDeviceOutputs() const;

  Backend backend() const { return backend_; }
  const PatchMatchOptions& options() const { return options_; }
  const EstimatorResources& resources() const { return resources_; }

 private:
  PatchMatchOptions options_;
  Backend backend_;
  EstimatorResources resources_;
  // Coarse-to-fine estimates: the coarser copies of keyed images, kept until forget(key).
  mutable mvs::ScaledImageCache scaled_images_;
  // Device state (image pool, work buffers, stream): a cache that estimate()
  // fills, hence mutable; mutex_ serialises its users.
  mutable std::mutex mutex_;
  mutable std::unique_ptr<mvs::CudaState, mvs::CudaStateDeleter> cuda_;
};

// Whether this build has the CUDA backend and a usable GPU; `description`
// names the GPU or says why none is usable.
bool cudaBackendAvailable(std::string* description);

// `requested`, or for kAuto kCuda when cudaBackendAvailable() and otherwise
// kCpu (then `why_not_gpu` says why, when given).
Backend resolvedBackend(Backend requested, std::string* why_not_gpu = nullptr);

}  // namespace amhmvs
