// Fusion with a backend: the CPU loop of fuseDepthMaps, or the same per-pixel
// check (fusion_pixel.h) as a CUDA kernel, one thread per reference pixel,
// over depth maps kept on the GPU. Results agree with fuseDepthMaps up to
// floating-point rounding (the GPU contracts multiply-adds).
//
//   DepthMapFuser fuser(Backend::kAuto);
//   FusionResult fused = fuser.fuse(views, options);  // as fuseDepthMaps
//
// Residency: a view with a key (FusionView::key >= 0) has its depth, normal,
// cost and colour uploaded once and kept while they fit the device budget
// (least recently used evicted first, counted); unkeyed views are uploaded
// for one call. A map just estimated on the same GPU (setDeviceSources) is
// copied on the device instead of uploaded. Device buffers of maps that left
// are reused (no allocation per keyframe).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct FuserResources {
  // Device bytes of resident depth maps (a 640x480 map with normals, cost and
  // colour takes 6.1 MB).
  size_t device_map_budget_bytes = size_t{512} << 20;
};

struct FuserCacheStats {
  uint64_t uploads = 0;     // maps copied to the device (from the host or from device_copies)
  uint64_t device_copies = 0;  // of those: depth, normal and cost copied on the device (setDeviceSources)
  uint64_t hits = 0;        // keyed maps found there
  uint64_t evictions = 0;   // keyed maps dropped to stay in the budget
  uint64_t forgotten = 0;   // keyed maps dropped by forget() / forgetAll()
  size_t resident_bytes = 0;
};

// Where the GPU fuser's time went: wall clock summed since construction
// (zeros on the CPU), for the benchmark's stage split.
struct FuserTimes {
  uint64_t references = 0;  // reference views fused
  double place_ms = 0;      // maps onto the device (uploads, device copies), "used" marks cleared
  double check_ms = 0;      // consistency kernel, compaction and marks, until the GPU is done
  double download_ms = 0;   // emitted points straight into the caller's KeyframePoints
  double convert_ms = 0;    // getting that vector ready (made while the GPU worked)
  double agreement_ms = 0;  // countAgreement's / publishDepth's kernel and downloads (confidence)
};

namespace fusion {
class ReferenceFusion;
}

class DepthMapFuser {
 public:
  // kAuto: CUDA when this build has it and a GPU is usable, else the CPU.
  // kCuda without a usable GPU throws BackendError.
  explicit DepthMapFuser(Backend backend = Backend::kAuto, const FuserResources& resources = FuserResources());
  ~DepthMapFuser();
  DepthMapFuser(const DepthMapFuser&) = delete;
  DepthMapFuser& operator=(const DepthMapFuser&) = delete;

  // As fuseDepthMaps (same InputErrors); BackendError when the GPU fails
  // (e.g. out of memory), after which the fuser can still be used.
  FusionResult fuse(const std::vector<FusionView>& views, const FusionOptions& options);

  // depth_confidence.h's countAgreement where the fuser runs: on the GPU
  // from the resident maps (views with keys just fused are not uploaded
  // again), on the CPU that function. Same InputErrors; BackendError as fuse.
  AgreementCounts countAgreement(const FusionView& reference, const std::vector<FusionView>& views,
                                 const FusionOptions& checks);
  // depth_confidence.h's publishDepth where the fuser runs: on the GPU the
  // counts, the confidence and the published depth in one kernel (one
  // download of each image, no host pass). Same results, InputErrors and
  // BackendError as countAgreement.
  PublishedDepth publishDepth(const FusionView& reference, const std::vector<FusionView>& views,
                              const ConfidenceOptions& options,
                              const ConfidenceCalibration& calibration = defaultConfidenceCalibration());
  // The maps under `key` (a depth map that was replaced or whose keyframe
  // left the store) or under every key leave the device now, not when the
  // budget pushes them out. No-op on the CPU and for unknown keys.
  void forget(int64_t key);
  void forgetAll();

  // The estimator's last outputs (DepthEstimator::lastDeviceOutputs): a view
  // that borrows exactly the host images of one of `maps` is copied from it
  // on the device (its colour is still uploaded). An empty list clears them.
  // The device memory must stay unchanged while set. No-op on the CPU.
  void setDeviceSources(const std::vector<DeviceDepthMap>& maps);
  // One map (an empty one clears them).
  void setDeviceSource(const DeviceDepthMap& map);

  Backend backend() const { return backend_; }
  FuserCacheStats cacheStats() const;
  FuserTimes times() const;

 private:
  Backend backend_;
  std::unique_ptr<fusion::ReferenceFusion> cuda_;
};

}  // namespace amhmvs
