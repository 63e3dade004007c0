// CUDA backend of the fusion: the per-pixel check of fusion_pixel.h, one
// thread per reference pixel, over depth maps kept on the device under their
// keys. Emitted points are compacted in pixel order on the device (the CPU
// loop's order) and only they are downloaded; "used" marks stay on the device.
#include <cuda_runtime.h>

#include <cub/device/device_select.cuh>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <vector>

#include "mapping/fusion_driver.h"
#include "amhmvs_mapping/core/prepared_vector.h"
#include "amhmvs_mapping/core/stopwatch.h"
#include "cuda_check.h"

namespace amhmvs {
namespace fusion {
namespace {

constexpr int kBlock = 16;
using Clock = std::chrono::steady_clock;

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

// Agreement counts of every reference pixel (depth_confidence.h), 0 where it
// has no usable estimate; with `confidence` set also the calibrated
// confidence and the published depth (confidence_pixel.h).
__global__ void agreementKernel(ViewData ref, const ViewData* sources, int source_count, Checks checks,
                                uint8_t* seen, uint8_t* agreeing, confidence::TableView table,
                                float min_probability, float* confidence_out, float* published) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= ref.width || y >= ref.height) return;
  int seen_count = 0, agreeing_count = 0;
  countAgreement(ref, sources, source_count, checks, x, y, &seen_count, &agreeing_count);
  const int pixel = ref.pixelIndex(x, y);
  seen[pixel] = static_cast<uint8_t>(min(seen_count, 255));
  agreeing[pixel] = static_cast<uint8_t>(min(agreeing_count, 255));
  if (!confidence_out) return;
  const float depth = ref.depth[pixel];
  const float probability = confidence::pixelConfidence(table, seen[pixel], agreeing[pixel], depth,
                                                        ref.cost ? ref.cost[pixel] : 0.0f);
  confidence_out[pixel] = probability;
  published[pixel] = confidence::publishedDepth(depth, probability, min_probability);
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

// Spare buffer sets kept for the next maps (a forgotten or evicted map's):
// no cudaMalloc / cudaFree (which waits for the whole device) per keyframe.
constexpr size_t kMaxSpareMaps = 2;

// `image` into `buffer` (reused when large enough), from the host or, when
// `device` is set, from that device copy of the same pixels.
template <typename T>
void copyImage(const ImageView<T>& image, const T* device, cuda::DeviceBuffer<T>* buffer, cudaStream_t stream) {
  if (image.empty()) return;
  const size_t count = image.pixelCount() * image.channels;
  buffer->reserve(count);
  if (device) {
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(buffer->get(), device, count * sizeof(T), cudaMemcpyDeviceToDevice, stream));
  } else {
    buffer->uploadAsync(image.data, count, stream);
  }
}

class CudaReferenceFusion : public ReferenceFusion {
 public:
  explicit CudaReferenceFusion(const FuserResources& resources) : resources_(resources) {}

  void begin(const std::vector<const FusionView*>& views, const FusionOptions& options) override {
    const Clock::time_point start = Clock::now();
    ++call_;
    // The last call's uploads from the colour staging are done (it is reused).
    stream_.synchronize();
    color_staged_ = 0;
    views_ = views;
    checks_ = checks(options);
    for (DeviceMaps& maps : scratch_) release(std::move(maps));
    scratch_.clear();
    scratch_.reserve(views.size());  // place() keeps pointers into it
    maps_.assign(views.size(), nullptr);
    const uint64_t device_copies = stats_.device_copies;
    for (size_t i = 0; i < views.size(); ++i) maps_[i] = place(*views[i]);
    // The device copies read the estimator's outputs, which its next
    // estimate overwrites; a call without a reference would not wait later.
    if (stats_.device_copies != device_copies) stream_.synchronize();
    marking_ = options.fuse_each_pixel_once;
    if (!marking_) return;
    if (used_.size() < views.size()) used_.resize(views.size());
    for (size_t i = 0; i < views.size(); ++i) {
      used_[i].reserve(views[i]->depth.pixelCount());
      AMHMVS_CUDA_CHECK(cudaMemsetAsync(used_[i].get(), 0, used_[i].bytes(), stream_.get()));
    }
    times_.place_ms += millisecondsSince(start);
  }

  size_t fuseReference(int reference, const std::vector<int>& sources, KeyframePoints* points) override {
    Clock::time_point start = Clock::now();
    ++times_.references;
    const cudaStream_t stream = stream_.get();
    const ViewData ref = data(reference);
    const int count = static_cast<int>(sources.size());
    const size_t pixels = static_cast<size_t>(ref.width) * ref.height;
    const bool marking = marking_;
    uploadSources(sources);
    pixels_.reserve(pixels);
    compact_.reserve(pixels);
    emitted_.reserve(pixels);
    if (marking) support_.reserve(pixels * std::max(count, 1));
    candidates_.reserve(1);
    selected_.reserve(1);
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
    times_.check_ms += millisecondsSince(start);
    start = Clock::now();
    const size_t emitted = static_cast<size_t>(selected_count);
    // Into the caller's points, laid out alike (fusion_driver.h).
    KeyframePoint* out = nullptr;
    if (points->empty()) {
      // The usual case (the mapper's one reference): into a vector made
      // while the GPU worked. The next one is sized for 1/8 more than this
      // map emitted: its unused tail stays with the kept points (more
      // headroom cost host memory in the 10,000-keyframe replay), and a map
      // that emits more than that takes the slower path once.
      *points = prepared_.take(emitted, std::min(pixels, emitted + emitted / 8 + 256));
      out = points->data();
    } else {
      points->resize(points->size() + emitted);
      out = points->data() + points->size() - emitted;
    }
    times_.convert_ms += millisecondsSince(start);
    start = Clock::now();
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(static_cast<void*>(out), compact_.get(), emitted * sizeof(FusedPoint),
                                      cudaMemcpyDeviceToHost, stream));
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    times_.download_ms += millisecondsSince(start);
    return static_cast<size_t>(candidates);
  }

  AgreementCounts countAgreement(int reference, const std::vector<int>& sources) override {
    return publish(reference, sources, nullptr, 0).counts;
  }

  PublishedDepth publishDepth(int reference, const std::vector<int>& sources,
                              const ConfidenceCalibration& calibration, float min_probability) override {
    return publish(reference, sources, &calibration, min_probability);
  }

  FuserTimes times() const override { return times_; }

  FuserCacheStats cacheStats() const override {
    FuserCacheStats stats = stats_;
    stats.resident_bytes = resident_bytes_;
    return stats;
  }

  void forget(int64_t key) override {
    const auto found = resident_.find(key);
    if (found == resident_.end()) return;
    resident_bytes_ -= found->second.bytes();
    release(std::move(found->second));
    resident_.erase(found);
    ++stats_.forgotten;
  }

  void forgetAll() override {
    stats_.forgotten += resident_.size();
    resident_.clear();
    resident_bytes_ = 0;
  }

  void setDeviceSources(const std::vector<DeviceDepthMap>& maps) override { device_sources_ = maps; }

 private:
  // The agreement counts of views[reference] against views[sources]; with
  // a calibration also the confidence and the published depth, all in one
  // kernel, downloaded straight into the result's images.
  PublishedDepth publish(int reference, const std::vector<int>& sources, const ConfidenceCalibration* calibration,
                         float min_probability) {
    const Clock::time_point start = Clock::now();
    const cudaStream_t stream = stream_.get();
    const ViewData ref = data(reference);
    const int count = static_cast<int>(sources.size());
    uploadSources(sources);
    const size_t pixels = static_cast<size_t>(ref.width) * ref.height;
    seen_.reserve(pixels);
    agreeing_.reserve(pixels);
    confidence::TableView table{};
    if (calibration) {
      confidence_.reserve(pixels);
      published_.reserve(pixels);
      // Small and pageable: copied before the call returns.
      table_.reserve(calibration->probability.size() + calibration->cost_edges.size());
      table_.uploadAsync(calibration->probability.data(), calibration->probability.size(), stream);
      AMHMVS_CUDA_CHECK(cudaMemcpyAsync(table_.get() + calibration->probability.size(),
                                        calibration->cost_edges.data(),
                                        calibration->cost_edges.size() * sizeof(float), cudaMemcpyHostToDevice,
                                        stream));
      table = calibration->view();
      table.probability = table_.get();
      table.cost_edges = table_.get() + calibration->probability.size();
    }
    const dim3 block(kBlock, kBlock);
    const dim3 grid((ref.width + kBlock - 1) / kBlock, (ref.height + kBlock - 1) / kBlock);
    agreementKernel<<<grid, block, 0, stream>>>(ref, sources_.get(), count, checks_, seen_.get(), agreeing_.get(),
                                                table, min_probability,
                                                calibration ? confidence_.get() : nullptr, published_.get());
    AMHMVS_CUDA_CHECK_LAUNCH();
    // The host images are made while the kernel runs.
    PublishedDepth out;
    out.counts = AgreementCounts{ImageU8(ref.width, ref.height), ImageU8(ref.width, ref.height)};
    seen_.downloadAsync(out.counts.seen.data.data(), pixels, stream);
    agreeing_.downloadAsync(out.counts.agreeing.data.data(), pixels, stream);
    if (calibration) {
      out.confidence = ImageF(ref.width, ref.height);
      out.depth = ImageF(ref.width, ref.height);
      out.min_probability = min_probability;
      confidence_.downloadAsync(out.confidence.data.data(), pixels, stream);
      published_.downloadAsync(out.depth.data.data(), pixels, stream);
    }
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    times_.agreement_ms += millisecondsSince(start);
    return out;
  }

  // The sources' view data (and their "used" marks when marking) onto the
  // device for the next kernel on the stream.
  void uploadSources(const std::vector<int>& sources) {
    const int count = static_cast<int>(sources.size());
    std::vector<ViewData> source_data;
    std::vector<uint8_t*> source_used;
    for (int s : sources) {
      source_data.push_back(data(s));
      source_used.push_back(marking_ ? used_[s].get() : nullptr);
    }
    sources_.reserve(std::max(count, 1));
    source_used_.reserve(std::max(count, 1));
    if (count == 0) return;
    // Small, pageable: the copies complete before the calls return.
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(sources_.get(), source_data.data(), count * sizeof(ViewData),
                                      cudaMemcpyHostToDevice, stream_.get()));
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(source_used_.get(), source_used.data(), count * sizeof(uint8_t*),
                                      cudaMemcpyHostToDevice, stream_.get()));
  }

  ViewData data(int index) const {
    const DeviceMaps& m = *maps_[index];
    return viewData(*views_[index], m.depth.get(), m.normal.get(), m.cost.get(), m.color.get(),
                    marking_ ? used_[index].get() : nullptr);
  }

  // The device source (an estimator's outputs) whose host images `view`
  // borrows, if any: its maps are then copied on the device.
  const DeviceDepthMap* onDevice(const FusionView& view) const {
    for (const DeviceDepthMap& source : device_sources_) {
      if (!source.empty() && view.depth.width == source.width && view.depth.height == source.height &&
          view.depth.data == source.host_depth && view.normal.data == source.host_normal &&
          (view.cost.empty() || view.cost.data == source.host_cost))
        return &source;
    }
    return nullptr;
  }

  DeviceMaps upload(const FusionView& view) {
    DeviceMaps maps = acquire();
    const cudaStream_t stream = stream_.get();
    const DeviceDepthMap* source = onDevice(view);
    const bool on_device = source != nullptr;
    copyImage(view.depth, on_device ? source->depth : nullptr, &maps.depth, stream);
    copyImage(view.normal, on_device ? source->normal : nullptr, &maps.normal, stream);
    copyImage(view.cost, on_device ? source->cost : nullptr, &maps.cost, stream);
    copyImage<uint8_t>(stagedColor(view.color), nullptr, &maps.color, stream);
    maps.last_call = call_;
    ++stats_.uploads;
    stats_.device_copies += on_device;
    return maps;
  }

  // `color` copied into the pinned staging memory (an asynchronous upload
  // from pageable memory waits for a driver-side copy: ~0.5 ms per 640x480
  // keyframe on the pipeline's critical path).
  ImageViewU8 stagedColor(const ImageViewU8& color) {
    const size_t bytes = color.pixelCount() * color.channels;
    if (bytes == 0) return color;
    if (color_staged_ + bytes > color_staging_.bytes()) {
      stream_.synchronize();  // earlier uploads from the staging are done
      color_staged_ = 0;
      color_staging_.reserve(4 * bytes);  // a call's new maps rarely need more
    }
    uint8_t* staged = color_staging_.get() + color_staged_;
    std::memcpy(staged, color.data, bytes);
    color_staged_ += bytes;
    return ImageViewU8(staged, color.width, color.height, color.channels);
  }

  // A spare buffer set (the largest first: it fits most maps), else empty
  // buffers that copyImage allocates.
  DeviceMaps acquire() {
    if (spare_.empty()) return DeviceMaps();
    const auto largest = std::max_element(spare_.begin(), spare_.end(), [](const DeviceMaps& a, const DeviceMaps& b) {
      return a.bytes() < b.bytes();
    });
    DeviceMaps maps = std::move(*largest);
    spare_.erase(largest);
    return maps;
  }

  // Keeps the buffers of a map that left for the next one (at most
  // kMaxSpareMaps sets besides the budget's resident maps); frees the rest.
  // Queued copies into them are ordered before any later use on this stream.
  void release(DeviceMaps maps) {
    if (spare_.size() < kMaxSpareMaps) spare_.push_back(std::move(maps));
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
      release(std::move(oldest->second));
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
  std::vector<DeviceMaps> spare_;  // buffers of maps that left, for the next ones
  std::vector<DeviceDepthMap> device_sources_;
  std::vector<DeviceMaps*> maps_;
  std::vector<cuda::DeviceBuffer<uint8_t>> used_;  // per view; grow only
  cuda::DeviceBuffer<ViewData> sources_;
  cuda::DeviceBuffer<uint8_t*> source_used_;
  cuda::DeviceBuffer<FusedPoint> pixels_, compact_;
  cuda::DeviceBuffer<uint8_t> emitted_;
  cuda::DeviceBuffer<uint8_t> seen_, agreeing_;  // agreement counts
  cuda::DeviceBuffer<float> confidence_, published_, table_;  // the confidence, the published depth, its table
  cuda::DeviceBuffer<int> support_;
  bool marking_ = false;
  cuda::DeviceBuffer<unsigned long long> candidates_;
  cuda::DeviceBuffer<int> selected_;
  cuda::DeviceBuffer<uint8_t> temp_;
  cuda::PinnedBuffer<uint8_t> color_staging_;  // colour uploads of one call
  size_t color_staged_ = 0;                    // bytes of it in use
  FuserCacheStats stats_;
  FuserTimes times_;
  PreparedVector<KeyframePoint> prepared_;  // the next reference's output
};

}  // namespace

std::unique_ptr<ReferenceFusion> makeCudaReferenceFusion(const FuserResources& resources) {
  return std::make_unique<CudaReferenceFusion>(resources);
}

}  // namespace fusion
}  // namespace amhmvs
