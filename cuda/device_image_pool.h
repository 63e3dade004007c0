// Device-resident images of one estimator: a layered 8-bit texture whose
// layers are slots of the largest image size seen so far.
//
// An image with a key (DepthProblem::reference_key / source_keys) is uploaded
// once and stays in its slot across estimates while the byte budget allows;
// when a slot is needed and none is free, the least recently used keyed image
// that the current estimate does not use is evicted. Images without a key
// take a scratch slot for one estimate. Images are padded clamp-to-edge to
// the slot size (padLayer), so sampling a slot equals sampling the image.
//
// Not thread-safe: the estimator serialises its calls.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "cuda_check.h"
#include "layered_texture.h"

namespace amhmvs {
namespace cuda {

// An image the current estimate needs and its key (kNoImageKey: scratch).
struct PoolRequest {
  ImageViewU8 image;
  int64_t key;
};

class DeviceImagePool {
 public:
  explicit DeviceImagePool(size_t budget_bytes) : budget_bytes_(budget_bytes) {
    int device = 0;
    AMHMVS_CUDA_CHECK(cudaGetDevice(&device));
    AMHMVS_CUDA_CHECK(cudaDeviceGetAttribute(&max_layers_, cudaDevAttrMaxTexture2DLayeredLayers, device));
  }
  ~DeviceImagePool() { releaseArray(); }
  DeviceImagePool(const DeviceImagePool&) = delete;
  DeviceImagePool& operator=(const DeviceImagePool&) = delete;

  // Makes every requested image resident and returns its layer (same order).
  // Uploads are queued on `stream` from `staging`, which must stay untouched
  // until the stream has passed them. Call finish() after the estimate.
  std::vector<int> place(const std::vector<PoolRequest>& requests, cudaStream_t stream,
                         PinnedBuffer<uint8_t>* staging) {
    ++clock_;
    fitSlotSize(requests, stream);
    // Hits first, so that no eviction below takes a slot this estimate uses.
    std::vector<int> layers(requests.size(), -1);
    std::unordered_set<int64_t> missing_keys;
    size_t missing = 0;
    for (size_t i = 0; i < requests.size(); ++i) {
      const int64_t key = requests[i].key;
      const auto found = key == kNoImageKey ? slot_of_key_.end() : slot_of_key_.find(key);
      if (found != slot_of_key_.end()) {
        Slot& slot = slots_[found->second];
        if (!slot.sameSizeAs(requests[i].image)) {
          throw InputError("image key " + std::to_string(key) + " was " + std::to_string(slot.width) + "x" +
                           std::to_string(slot.height) + " and is now " + std::to_string(requests[i].image.width) +
                           "x" + std::to_string(requests[i].image.height) + " without forget()");
        }
        if (slot.last_use != clock_) ++stats_.hits;  // a key twice in one problem is one hit
        slot.last_use = clock_;
        slot.in_use = true;
        layers[i] = found->second;
      } else if (key == kNoImageKey || missing_keys.insert(key).second) {
        ++missing;
      }
    }
    growFor(missing, stream);

    staging->reserve(missing * slotBytes());
    size_t staged = 0;
    for (size_t i = 0; i < requests.size(); ++i) {
      if (layers[i] >= 0) continue;
      const int64_t key = requests[i].key;
      if (key != kNoImageKey) {
        const auto found = slot_of_key_.find(key);
        if (found != slot_of_key_.end()) {  // uploaded above for an earlier request
          layers[i] = found->second;
          continue;
        }
      }
      const int layer = takeSlot();
      Slot& slot = slots_[layer];
      slot.key = key;
      slot.width = requests[i].image.width;
      slot.height = requests[i].image.height;
      slot.last_use = clock_;
      slot.in_use = true;
      if (key != kNoImageKey) {
        slot_of_key_[key] = layer;
        ++stats_.uploads;
      } else {
        ++stats_.unkeyed_uploads;
      }
      uint8_t* host = staging->get() + staged * slotBytes();
      padLayer(requests[i].image, width_, height_, host);
      upload(host, layer, stream);
      ++staged;
      layers[i] = layer;
    }
    return layers;
  }

  // After an estimate: scratch slots become free; keyed images beyond the
  // budget are evicted, least recently used first.
  void finish() {
    for (Slot& slot : slots_) {
      slot.in_use = false;
      if (slot.key == kNoImageKey) slot.width = slot.height = 0;
    }
    while (!slot_of_key_.empty() && slot_of_key_.size() > budgetSlots()) evict(leastRecentlyUsed());
  }

  // A new budget holds from the next finish() on.
  void setBudget(size_t budget_bytes) { budget_bytes_ = budget_bytes; }

  void forget(int64_t key) {
    const auto found = slot_of_key_.find(key);
    if (found == slot_of_key_.end()) return;
    clearSlot(found->second);
    ++stats_.forgotten;
  }
  void forgetAll() {
    while (!slot_of_key_.empty()) forget(slot_of_key_.begin()->first);
  }

  // Copies the image of `layer` into a linear width x height buffer.
  void copyToLinear(int layer, int width, int height, uint8_t* device, cudaStream_t stream) const {
    cudaMemcpy3DParms copy = {};
    copy.srcArray = array_;
    copy.srcPos = make_cudaPos(0, 0, layer);
    copy.dstPtr = make_cudaPitchedPtr(device, width, width, height);
    copy.extent = make_cudaExtent(width, height, 1);
    copy.kind = cudaMemcpyDeviceToDevice;
    AMHMVS_CUDA_CHECK(cudaMemcpy3DAsync(&copy, stream));
  }

  cudaTextureObject_t texture() const { return texture_; }

  DeviceCacheStats stats() const {
    DeviceCacheStats out = stats_;
    out.resident_images = slot_of_key_.size();
    out.resident_bytes = slot_of_key_.size() * slotBytes();
    out.budget_bytes = budget_bytes_;
    out.slot_bytes = slotBytes();
    out.pool_bytes = slots_.size() * slotBytes();
    return out;
  }

 private:
  struct Slot {
    int64_t key = kNoImageKey;  // kNoImageKey: free, or scratch while in_use
    int width = 0, height = 0;  // of the image in it
    uint64_t last_use = 0;      // clock_ of the last estimate that used it
    bool in_use = false;        // by the current estimate

    bool sameSizeAs(const ImageViewU8& image) const {
      return width == image.width && height == image.height;
    }
  };

  size_t slotBytes() const { return static_cast<size_t>(width_) * height_; }
  // Keyed images kept between estimates: what the budget holds, at most the
  // GPU's layer count (small images under a large budget would exceed it).
  size_t budgetSlots() const {
    return slotBytes() ? std::min(budget_bytes_ / slotBytes(), static_cast<size_t>(max_layers_)) : 0;
  }

  // Slots must hold the largest requested image; growing them drops every
  // resident image (their padding would be wrong), counted as evictions.
  void fitSlotSize(const std::vector<PoolRequest>& requests, cudaStream_t stream) {
    int width = width_, height = height_;
    for (const PoolRequest& request : requests) {
      width = std::max(width, request.image.width);
      height = std::max(height, request.image.height);
    }
    if (width == width_ && height == height_) return;
    stats_.evictions += slot_of_key_.size();
    slot_of_key_.clear();
    const size_t layers = slots_.size();
    synchronizeAndRelease(stream);
    width_ = width;
    height_ = height;
    allocate(layers);
  }

  // Room for `missing` new images: all resident ones are kept while the
  // budget allows, else at least the current estimate's images fit (the
  // least recently used others are evicted by takeSlot()).
  void growFor(size_t missing, cudaStream_t stream) {
    size_t in_use = 0;
    for (const Slot& slot : slots_) in_use += slot.in_use;
    const size_t keep_all = std::min(budgetSlots(), slot_of_key_.size() + missing);
    const size_t needed = std::max(in_use + missing, keep_all);
    if (needed <= slots_.size()) return;
    // Geometric growth within the budget: few reallocations on a long run.
    const size_t target = std::max(needed, std::min(2 * slots_.size(), std::max(budgetSlots(), needed)));
    if (target > static_cast<size_t>(max_layers_)) {
      throw BackendError("one estimate needs " + std::to_string(target) + " texture layers; the GPU allows " +
                         std::to_string(max_layers_));
    }
    cudaArray_t old = array_;
    const size_t old_layers = slots_.size();
    array_ = nullptr;
    if (texture_) AMHMVS_CUDA_CHECK(cudaDestroyTextureObject(texture_));
    texture_ = 0;
    try {
      allocate(target);
    } catch (...) {
      cudaFreeArray(old);
      throw;
    }
    if (old && old_layers > 0) {  // keep the resident images
      cudaMemcpy3DParms copy = {};
      copy.srcArray = old;
      copy.dstArray = array_;
      copy.extent = make_cudaExtent(width_, height_, old_layers);
      copy.kind = cudaMemcpyDeviceToDevice;
      AMHMVS_CUDA_CHECK(cudaMemcpy3DAsync(&copy, stream));
    }
    // The old array may still be read by queued copies.
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    if (old) AMHMVS_CUDA_CHECK(cudaFreeArray(old));
  }

  void allocate(size_t layers) {
    slots_.resize(layers);
    if (layers == 0) return;
    const cudaChannelFormatDesc format = cudaCreateChannelDesc<uint8_t>();
    AMHMVS_CUDA_CHECK(cudaMalloc3DArray(&array_, &format, make_cudaExtent(width_, height_, layers),
                                        cudaArrayLayered));
    texture_ = makeLayeredTexture(array_);
  }

  void synchronizeAndRelease(cudaStream_t stream) {
    AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream));
    releaseArray();
    for (Slot& slot : slots_) slot = Slot();
  }

  void releaseArray() {
    if (texture_) cudaDestroyTextureObject(texture_);
    if (array_) cudaFreeArray(array_);
    texture_ = 0;
    array_ = nullptr;
  }

  // A free slot, else the least recently used keyed slot not in use.
  int takeSlot() {
    for (size_t i = 0; i < slots_.size(); ++i) {
      if (!slots_[i].in_use && slots_[i].key == kNoImageKey) return static_cast<int>(i);
    }
    const int victim = leastRecentlyUsed();
    if (victim < 0) throw BackendError("device image pool: no slot left (internal error)");
    evict(victim);
    return victim;
  }

  int leastRecentlyUsed() const {
    int best = -1;
    for (size_t i = 0; i < slots_.size(); ++i) {
      const Slot& slot = slots_[i];
      if (slot.in_use || slot.key == kNoImageKey) continue;
      if (best < 0 || slot.last_use < slots_[best].last_use) best = static_cast<int>(i);
    }
    return best;
  }

  void evict(int layer) {
    clearSlot(layer);
    ++stats_.evictions;
  }

  void clearSlot(int layer) {
    slot_of_key_.erase(slots_[layer].key);
    slots_[layer] = Slot();
  }

  void upload(const uint8_t* host, int layer, cudaStream_t stream) {
    cudaMemcpy3DParms copy = {};
    copy.srcPtr = make_cudaPitchedPtr(const_cast<uint8_t*>(host), width_, width_, height_);
    copy.dstArray = array_;
    copy.dstPos = make_cudaPos(0, 0, layer);
    copy.extent = make_cudaExtent(width_, height_, 1);
    copy.kind = cudaMemcpyHostToDevice;
    AMHMVS_CUDA_CHECK(cudaMemcpy3DAsync(&copy, stream));
  }

  size_t budget_bytes_;
  int max_layers_ = 0;
  int width_ = 0, height_ = 0;  // of a slot
  cudaArray_t array_ = nullptr;
  cudaTextureObject_t texture_ = 0;
  std::vector<Slot> slots_;  // one per layer
  std::unordered_map<int64_t, int> slot_of_key_;
  uint64_t clock_ = 0;  // estimates so far
  DeviceCacheStats stats_;
};

}  // namespace cuda
}  // namespace amhmvs
