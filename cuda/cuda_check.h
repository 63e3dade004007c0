// Checked CUDA calls and RAII owners of device memory and textures.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <string>
#include <utility>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace cuda {

// Throws BackendError naming the call site and CUDA's message; out-of-memory
// is said in plain words so callers and users can act on it.
inline void check(cudaError_t status, const char* call, const char* file, int line) {
  if (status == cudaSuccess) return;
  cudaGetLastError();  // clear a sticky non-fatal error state
  std::string message = std::string(call) + " failed at " + file + ":" + std::to_string(line) +
                        ": " + cudaGetErrorString(status);
  if (status == cudaErrorMemoryAllocation) message = "out of GPU memory: " + message;
  throw BackendError(message);
}

#define AMHMVS_CUDA_CHECK(call) ::amhmvs::cuda::check((call), #call, __FILE__, __LINE__)
// After a kernel launch: launch errors now, execution errors at the next sync.
#define AMHMVS_CUDA_CHECK_LAUNCH() AMHMVS_CUDA_CHECK(cudaGetLastError())

template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(size_t count) : count_(count) {
    if (count_ > 0) AMHMVS_CUDA_CHECK(cudaMalloc(&data_, count_ * sizeof(T)));
  }
  ~DeviceBuffer() {
    if (data_) cudaFree(data_);
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& other) noexcept { swap(other); }
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    swap(other);
    return *this;
  }

  T* get() const { return data_; }
  size_t size() const { return count_; }
  size_t bytes() const { return count_ * sizeof(T); }
  void upload(const T* host) { AMHMVS_CUDA_CHECK(cudaMemcpy(data_, host, bytes(), cudaMemcpyHostToDevice)); }
  void download(T* host) const {
    AMHMVS_CUDA_CHECK(cudaMemcpy(host, data_, bytes(), cudaMemcpyDeviceToHost));
  }
  // The first `count` elements, queued on `stream` (asynchronous when the
  // host memory is pinned).
  void uploadAsync(const T* host, size_t count, cudaStream_t stream) {
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(data_, host, count * sizeof(T), cudaMemcpyHostToDevice, stream));
  }
  void downloadAsync(T* host, size_t count, cudaStream_t stream) const {
    AMHMVS_CUDA_CHECK(cudaMemcpyAsync(host, data_, count * sizeof(T), cudaMemcpyDeviceToHost, stream));
  }
  // Holds at least `count` elements afterwards; never shrinks (a pool
  // reused across estimates). Contents are not kept when it grows.
  void reserve(size_t count) {
    if (count > count_) *this = DeviceBuffer(count);
  }

 private:
  void swap(DeviceBuffer& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(count_, other.count_);
  }
  T* data_ = nullptr;
  size_t count_ = 0;
};

// Page-locked host memory: the source of asynchronous uploads.
template <typename T>
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  ~PinnedBuffer() {
    if (data_) cudaFreeHost(data_);
  }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;

  // At least `count` elements; never shrinks. The caller makes sure no copy
  // still reads the old memory (the estimator synchronises its stream at the
  // end of every estimate).
  void reserve(size_t count) {
    if (count <= count_) return;
    if (data_) AMHMVS_CUDA_CHECK(cudaFreeHost(data_));
    data_ = nullptr;
    count_ = 0;
    AMHMVS_CUDA_CHECK(cudaHostAlloc(reinterpret_cast<void**>(&data_), count * sizeof(T), cudaHostAllocDefault));
    count_ = count;
  }
  T* get() const { return data_; }
  size_t bytes() const { return count_ * sizeof(T); }

 private:
  T* data_ = nullptr;
  size_t count_ = 0;
};

// A non-blocking stream (no implicit synchronisation with the legacy default
// stream): each estimator queues all its copies and kernels on its own.
class CudaStream {
 public:
  CudaStream() { AMHMVS_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking)); }
  ~CudaStream() { cudaStreamDestroy(stream_); }
  CudaStream(const CudaStream&) = delete;
  CudaStream& operator=(const CudaStream&) = delete;
  cudaStream_t get() const { return stream_; }
  void synchronize() const { AMHMVS_CUDA_CHECK(cudaStreamSynchronize(stream_)); }

 private:
  cudaStream_t stream_ = nullptr;
};

class CudaEvent {
 public:
  CudaEvent() { AMHMVS_CUDA_CHECK(cudaEventCreate(&event_)); }
  ~CudaEvent() { cudaEventDestroy(event_); }
  CudaEvent(const CudaEvent&) = delete;
  CudaEvent& operator=(const CudaEvent&) = delete;
  void record(cudaStream_t stream = nullptr) { AMHMVS_CUDA_CHECK(cudaEventRecord(event_, stream)); }
  cudaEvent_t get() const { return event_; }
  float millisecondsSince(const CudaEvent& start) const {
    AMHMVS_CUDA_CHECK(cudaEventSynchronize(event_));
    float ms = 0;
    AMHMVS_CUDA_CHECK(cudaEventElapsedTime(&ms, start.event_, event_));
    return ms;
  }

 private:
  cudaEvent_t event_ = nullptr;
};

}  // namespace cuda
}  // namespace amhmvs
