// CUDA backend of the fusion: the per-pixel check of fusion_pixel.h, one
// thread per reference pixel, over depth maps kept on the device under their
// keys. Emitted points are compacted in pixel order on the device (the CPU
// loop's order) and only they are downloaded; "used" marks stay on the device.
#include <cuda_runtime.h>

#include <cub/device/device_select.cuh>

#include <map>
#include <vector>

#include "../src/mapping/fusion_driver.h"
#include "cuda_check.h"

namespace amhmvs {
namespace fusion {
namespace {

constexpr int kBlock = 16;

__global__ void fuseKernel(ViewData ref, const ViewData* sources, int source_count, Checks checks,
                           FusedPoint* points, uint8_t* emitted, int* support,
                           unsigned long long* candidates) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  bool candidate = false;
  if (x < ref.width && y < ref.height) {
    const int pixel = ref.pixelIndex(x, y);
    bool kept = false;
    double depth;
    Vec3d normal;
    if (!(ref.used && ref.used[pixel]) && ref.pixel(x, y, checks.max_cost, &depth, &normal)) {
      candidate = true;
      kept = fusePixel(ref, sources, source_count, checks, x, y, &points[pixel],
                       support ? support + static_cast<size_t>(pixel) * source_count : nullptr);
    }
    emitted[pixel] = kept;
  }
  // One atomic per warp.
  const unsigned ballot = __ballot_sync(0xffffffffu, candidate);
  if ((threadIdx.x + threadIdx.y * blockDim.x) % 32 == 0 && ballot) {
    atomicAdd(candidates, static_cast<unsigned long long>(__popc(ballot)));
  }
}

// The marks of one reference: its emitted pixels and the source pixels that
// agreed with them (applied after the reference, as on the CPU).
__global__ void markKernel(int pixel_count, const uint8_t* emitted, const int* support,
                           int source_count, uint8_t* ref_used, uint8_t* const* source_used) {
  const int pixel = blockIdx.x * blockDim.x + threadIdx.x;
  if (pixel >= pixel_count || !emitted[pixel]) return;
  ref_used[pixel] = 1;
  for (int k = 0; k < source_count; ++k) {
    const int s = support[static_cast<size_t>(pixel) * source_count + k];
    if (s >= 0) source_used[k][s] = 1;
  }
}

// One view's maps on the device.
struct DeviceMaps {
  cuda::DeviceBuffer<float> depth, normal, cost;
  cuda::DeviceBuffer<uint8_t> color;
  uint64_t last_call = 0;
  size_t bytes() const { return depth.bytes() + normal.bytes() + cost.bytes() + color.bytes(); }
};

template <typename T>
void uploadImage(const ImageView<T>& image, cuda::DeviceBuffer<T>* buffer, cudaStream_t stream) {
  if (image.empty()) return;
  const size_t count = image.pixelCount() * image.channels;
  *buffer = cuda::DeviceBuffer<T>(count);
  buffer->uploadAsync(image.data, count, stream);
}

class CudaReferenceFusion : public ReferenceFusion {
 public:
  explicit CudaReferenceFusion(const FuserResources& resources) : resources_(resources) {}

  void begin(const std::vector<const FusionView*>& views, const FusionOptions& options) override {
    ++call_;
    views_ = views;
    checks_ = checks(options);
    scratch_.clear();
    scratch_.reserve(views.size());  // place() keeps pointers into it
    maps_.assign(views.size(), nullptr);
    for (size_t i = 0; i < views.size(); ++i) maps_[i] = place(*views[i]);
    marking_ = options.fuse_each_pixel_once;
    if (!marking_) return;
    if (used_.size() < views.size()) used_.resize(views.size());
    for (size_t i = 0; i < views.size(); ++i) {
      used_[i].reserve(views[i]->depth.pixelCount());
      AMHMVS_CUDA_CHECK(cudaMemsetAsync(used_[i].get(), 0, used_[i].bytes(), stream_.get()));
    }
  }

  size_t fuseReference(int reference, const std::vector<int>& sources, KeyframePoints* points) override {
    const cudaStream_t stream = stream_.get();
    const ViewData ref = data(reference);
    const int count = static_cast<int>(sources.size());
    std::vector<ViewData> source_data;
    std::vector<uint8_t*> source_used;
    for (int s : sources) {
      source_data.push_back(data(s));
      source_used.push_back(marking_ ? used_[s].get() : nullptr);
    }
    const size_t pixels = static_cast<size_t>(ref.width) * ref.height;
    const bool marking = marking_;
    sources_.reserve(std::max(count, 1));
    source_used_.reserve(std::max(count, 1));
    pixels_.reserve(pixels);
    compact_.reserve(pixels);
    emitted_.reserve(pixels);
    if (marking) support_.reserve(pixels * std::max(count, 1));
    candidates_.reserve(1);
    selected_.reserve(1);
    // Small, pageable: the copies complete before the calls return.
    if (count > 0) {
      AMHMVS_CUDA_CHECK(cudaMemcpyAsync(sources_.get(), source_data.data(), count * sizeof(ViewData),
                                        cudaMemcpyHostToDevice, stream));
      AMHMVS_CUDA_CHECK(cudaMemcpyAsync(source_used_.get(), source_used.data(), count * sizeof(uint8_t*),
                                        cudaMemcpyHostToDevice, stream));
    }
    AMHMVS_CUDA_CHECK(cudaMemsetAsync(candidates_.get(), 0, candidates_.bytes(), stream));

    const dim3 block(kBlock, kBlock);
    const dim3 grid((ref.width + kBlock - 1) / kBlock, (ref.height + kBlock - 1) / kBlock);
    fuseKernel<<<grid, block, 0, stream>>>(ref, sources_.get(), count, checks_, pixels_.get(), emitted_.get(),
                                           marking ? support_.get() : nullptr, candidates_.get());
    AMHMVS_CUDA_CHECK_LAUNCH();
    // Emitted points in pixel order (cub's selection is stable).
    const int n = static_cast<int>(pixels);
    int* selected = selected_.get();
    size_t temp_bytes = 0;
    AMHMVS_CUDA_CHECK(cub::DeviceSelect::Flagged(nullptr, temp_bytes, pixels_.get(), emitted_.get(),
                                                 compact_.get(), selected, n, stream));
    temp_.reserve(temp_bytes);
    AMHMVS_CUDA_CHECK(cub::DeviceSelect::Flagged(temp_.get(), temp_bytes, pixels_.get(), emitted_.get(),
                                                 compact_.get(), selected, n, stream));
    if (marking) {
      markKernel<<<(n + 255) / 256, 256, 0, stream>>>(n, emitted_.get(), support_.get(), count,
                                                       used_[reference].get(), source_used_.get());
      AMHMVS_CUDA_CHECK_LAUNCH();
    }
    unsigned long long candidates = 0;
    int selected_count = 0;
    candidates_.downloadAsync(&candidates, 1, stream);
    selected_.downloadAsync(&selected_count, 1, stream);
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    const size_t emitted = static_cast<size_t>(selected_count);
    host_points_.reserve(std::max<size_t>(emitted, 1));
    compact_.downloadAsync(host_points_.get(), emitted, stream);
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    points->reserve(points->size() + emitted);
    for (size_t i = 0; i < emitted; ++i) points->push_back(toKeyframePoint(host_points_.get()[i]));
    return static_cast<size_t>(candidates);
  }

  FuserCacheStats cacheStats() const override {
    FuserCacheStats stats = stats_;
    stats.resident_bytes = resident_bytes_;
    return stats;
  }

  void forget(int64_t key) override {
    const auto found = resident_.find(key);
    if (found == resident_.end()) return;
    resident_bytes_ -= found->second.bytes();
    resident_.erase(found);
    ++stats_.forgotten;
  }

  void forgetAll() override {
    stats_.forgotten += resident_.size();
    resident_.clear();
    resident_bytes_ = 0;
  }

 private:
  ViewData data(int index) const {
    const DeviceMaps& m = *maps_[index];
    return viewData(*views_[index], m.depth.get(), m.normal.get(), m.cost.get(), m.color.get(),
                    marking_ ? used_[index].get() : nullptr);
  }

  DeviceMaps upload(const FusionView& view) {
    DeviceMaps maps;
    const cudaStream_t stream = stream_.get();
    uploadImage(view.depth, &maps.depth, stream);
    uploadImage(view.normal, &maps.normal, stream);
    uploadImage(view.cost, &maps.cost, stream);
    uploadImage(view.color, &maps.color, stream);
    maps.last_call = call_;
    ++stats_.uploads;
    return maps;
  }

  // The device maps of a view: resident under its key, or scratch.
  DeviceMaps* place(const FusionView& view) {
    if (view.key < 0) {
      scratch_.push_back(upload(view));
      return &scratch_.back();
    }
    const auto found = resident_.find(view.key);
    if (found != resident_.end()) {
      ++stats_.hits;
      found->second.last_call = call_;
      return &found->second;
    }
    const size_t bytes = (view.depth.pixelCount() * 4 + view.cost.pixelCount()) * sizeof(float) +
                         view.color.pixelCount() * view.color.channels;
    evictFor(bytes);
    DeviceMaps& maps = resident_[view.key] = upload(view);
    resident_bytes_ += maps.bytes();
    return &maps;
  }

  // Least recently used first; never a map of the current call.
  void evictFor(size_t bytes) {
    while (resident_bytes_ + bytes > resources_.device_map_budget_bytes) {
      auto oldest = resident_.end();
      for (auto it = resident_.begin(); it != resident_.end(); ++it) {
        if (it->second.last_call == call_) continue;
        if (oldest == resident_.end() || it->second.last_call < oldest->second.last_call) oldest = it;
      }
      if (oldest == resident_.end()) return;  // all in use: over budget for this call
      resident_bytes_ -= oldest->second.bytes();
      resident_.erase(oldest);
      ++stats_.evictions;
    }
  }

  FuserResources resources_;
  cuda::CudaStream stream_;
  uint64_t call_ = 0;
  std::vector<const FusionView*> views_;
  Checks checks_{};
  std::map<int64_t, DeviceMaps> resident_;
  size_t resident_bytes_ = 0;
  std::vector<DeviceMaps> scratch_;
  std::vector<DeviceMaps*> maps_;
  std::vector<cuda::DeviceBuffer<uint8_t>> used_;  // per view; grow only
  cuda::DeviceBuffer<ViewData> sources_;
  cuda::DeviceBuffer<uint8_t*> source_used_;
  cuda::DeviceBuffer<FusedPoint> pixels_, compact_;
  cuda::DeviceBuffer<uint8_t> emitted_;
  cuda::DeviceBuffer<int> support_;
  bool marking_ = false;
  cuda::DeviceBuffer<unsigned long long> candidates_;
  cuda::DeviceBuffer<int> selected_;
  cuda::DeviceBuffer<uint8_t> temp_;
  cuda::PinnedBuffer<FusedPoint> host_points_;
  FuserCacheStats stats_;
};

}  // namespace

std::unique_ptr<ReferenceFusion> makeCudaReferenceFusion(const FuserResources& resources) {
  return std::make_unique<CudaReferenceFusion>(resources);
}

}  // namespace fusion
}  // namespace amhmvs
