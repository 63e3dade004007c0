// Internal: the part of fuseDepthMaps that does not depend on where the
// per-pixel check runs. The driver validates the input, orders the views by
// id (the order that decides which view keeps a point), skips references with
// fewer sources than min_consistent_views, and hands each reference to a
// backend (CPU loop in fusion.cpp, CUDA kernel in cuda/cuda_fusion.cu).
#pragma once

#include <cstddef>
#include <memory>
#include <type_traits>
#include <vector>

#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/depth_map_fuser.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/fusion_pixel.h"

namespace amhmvs {
namespace fusion {

class ReferenceFusion {
 public:
  virtual ~ReferenceFusion() = default;
  // Called once per fuseDepthMaps call with the views in processing order.
  virtual void begin(const std::vector<const FusionView*>& views, const FusionOptions& options) = 0;
  // Fuses views[reference] against views[sources] (indices into begin's
  // views): appends the emitted points in row-major pixel order, applies the
  // "used" marks when options.fuse_each_pixel_once, and returns the number of
  // candidate pixels (valid depth and normal, not used before).
  virtual size_t fuseReference(int reference, const std::vector<int>& sources,
                               KeyframePoints* points) = 0;
  virtual FuserCacheStats cacheStats() const { return {}; }
  virtual FuserTimes times() const { return {}; }
  // Drops the resident maps of `key` (no-op when none) or of every key.
  virtual void forget(int64_t key) { (void)key; }
  virtual void forgetAll() {}
  // Agreement counts (depth_confidence.h) of views[reference] against
  // views[sources] under begin's options (which mark nothing).
  virtual AgreementCounts countAgreement(int reference, const std::vector<int>& sources) {
    (void)reference;
    (void)sources;
    return {};
  }
  // depth_confidence.h's publishDepth of views[reference] against
  // views[sources] under begin's options (the calibration's checks).
  virtual PublishedDepth publishDepth(int reference, const std::vector<int>& sources,
                                      const ConfidenceCalibration& calibration, float min_probability) {
    (void)reference;
    (void)sources;
    (void)calibration;
    (void)min_probability;
    return {};
  }
  // Maps whose depth, normal and cost are on the device already (see
  // DepthMapFuser::setDeviceSources).
  virtual void setDeviceSources(const std::vector<DeviceDepthMap>& maps) { (void)maps; }
};

// The CUDA backend (cuda/cuda_fusion.cu; throws BackendError in builds
// without it).
std::unique_ptr<ReferenceFusion> makeCudaReferenceFusion(const FuserResources& resources);

// Throws InputError for views fuseDepthMaps cannot fuse (see fusion.h).
void checkViews(const std::vector<FusionView>& views, const FusionOptions& options);

FusionResult runFusion(const std::vector<FusionView>& views, const FusionOptions& options,
                       ReferenceFusion* backend);

// The views of an agreement count (depth_confidence.h), validated as fusion
// would read them: `views` without their source ids, then `reference` with
// all of them as its sources (last). Throws InputError like checkViews.
std::vector<FusionView> agreementViews(const FusionView& reference, const std::vector<FusionView>& views,
                                       const FusionOptions& checks);

// The camera of a view in the check's form, with the given maps (host or
// device pointers).
ViewData viewData(const FusionView& view, const float* depth, const float* normal,
                  const float* cost, const uint8_t* color, const uint8_t* used);
Checks checks(const FusionOptions& options);
KeyframePoint toKeyframePoint(const FusedPoint& point);

// The GPU copies emitted FusedPoints byte for byte into KeyframePoints (no
// conversion pass on the host: on the pipeline's critical path that pass
// competed with the map update's threads for the cores).
static_assert(std::is_standard_layout<FusedPoint>::value && std::is_standard_layout<KeyframePoint>::value &&
                  sizeof(FusedPoint) == sizeof(KeyframePoint) &&
                  offsetof(FusedPoint, position) == offsetof(KeyframePoint, position) &&
                  offsetof(FusedPoint, normal) == offsetof(KeyframePoint, normal) &&
                  offsetof(FusedPoint, rgb) == offsetof(KeyframePoint, rgb) &&
                  offsetof(FusedPoint, confidence) == offsetof(KeyframePoint, confidence) &&
                  offsetof(FusedPoint, consistent_views) == offsetof(KeyframePoint, consistent_views),
              "FusedPoint and KeyframePoint must have the same layout");

}  // namespace fusion
}  // namespace amhmvs
