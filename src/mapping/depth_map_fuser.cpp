#include "amhmvs_mapping/mapping/depth_map_fuser.h"

#include "amhmvs_mapping/core/error.h"
#include "fusion_driver.h"

namespace amhmvs {

DepthMapFuser::DepthMapFuser(Backend backend, const FuserResources& resources) : backend_(backend) {
  std::string why;
  const bool gpu = cudaBackendAvailable(&why);
  if (backend_ == Backend::kCuda && !gpu) throw BackendError("fusion on the GPU: " + why);
  if (backend_ == Backend::kAuto) backend_ = gpu ? Backend::kCuda : Backend::kCpu;
  if (backend_ == Backend::kCuda) cuda_ = fusion::makeCudaReferenceFusion(resources);
}

DepthMapFuser::~DepthMapFuser() = default;

FusionResult DepthMapFuser::fuse(const std::vector<FusionView>& views, const FusionOptions& options) {
  if (!cuda_) return fuseDepthMaps(views, options);
  return fusion::runFusion(views, options, cuda_.get());
}

namespace {

// The reference last, all other views its sources, begun on `backend`
// without marks (every view counts, whatever was fused before); returns the
// sources' indices.
std::vector<int> beginAgreement(const std::vector<FusionView>& all, const FusionOptions& checks,
                                fusion::ReferenceFusion* backend) {
  std::vector<const FusionView*> pointers;
  std::vector<int> sources;
  for (const FusionView& view : all) pointers.push_back(&view);
  for (int k = 0; k + 1 < static_cast<int>(all.size()); ++k) sources.push_back(k);
  FusionOptions counting = checks;
  counting.fuse_each_pixel_once = false;
  backend->begin(pointers, counting);
  return sources;
}

}  // namespace

AgreementCounts DepthMapFuser::countAgreement(const FusionView& reference, const std::vector<FusionView>& views,
                                              const FusionOptions& checks) {
  if (!cuda_) return amhmvs::countAgreement(reference, views, checks);
  const std::vector<FusionView> all = fusion::agreementViews(reference, views, checks);
  const std::vector<int> sources = beginAgreement(all, checks, cuda_.get());
  return cuda_->countAgreement(static_cast<int>(all.size()) - 1, sources);
}

PublishedDepth DepthMapFuser::publishDepth(const FusionView& reference, const std::vector<FusionView>& views,
                                           const ConfidenceOptions& options,
                                           const ConfidenceCalibration& calibration) {
  if (!cuda_) return amhmvs::publishDepth(reference, views, options, calibration);
  const std::vector<FusionView> all = fusion::agreementViews(reference, views, calibration.checks);
  const std::vector<int> sources = beginAgreement(all, calibration.checks, cuda_.get());
  return cuda_->publishDepth(static_cast<int>(all.size()) - 1, sources, calibration, options.min_probability);
}

void DepthMapFuser::forget(int64_t key) {
  if (cuda_) cuda_->forget(key);
}

void DepthMapFuser::forgetAll() {
  if (cuda_) cuda_->forgetAll();
}

void DepthMapFuser::setDeviceSources(const std::vector<DeviceDepthMap>& maps) {
  if (cuda_) cuda_->setDeviceSources(maps);
}

void DepthMapFuser::setDeviceSource(const DeviceDepthMap& map) {
  setDeviceSources(map.empty() ? std::vector<DeviceDepthMap>() : std::vector<DeviceDepthMap>{map});
}

FuserCacheStats DepthMapFuser::cacheStats() const { return cuda_ ? cuda_->cacheStats() : FuserCacheStats(); }

FuserTimes DepthMapFuser::times() const { return cuda_ ? cuda_->times() : FuserTimes(); }

}  // namespace amhmvs
