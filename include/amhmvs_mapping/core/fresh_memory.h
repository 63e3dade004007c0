// Fresh memory (a vector's new capacity) faults once per 4 KiB page when it is
// first written. One thread writing a keyframe's fused points (8.3 MB) into
// new memory took 5.4 ms on the GPU machine, 1.9 ms when all cores first
// touched the pages (session 7 probe; faults of different threads proceed in
// parallel). Per-keyframe buffers that are kept (points, voxel keys) are
// always fresh, so the hot path touches them from all cores first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace amhmvs {

// Touches each page of [data, data + bytes) from all cores (OpenMP) when the
// range is large enough to be worth it; the bytes written are zeros.
void touchPagesInParallel(void* data, size_t bytes);

// vector->reserve(capacity), with the new capacity touched from all cores.
// The touched bytes of the capacity are not objects
// until the vector constructs them there.
template <typename T>
void reserveTouched(std::vector<T>* vector, size_t capacity) {
  static_assert(std::is_trivially_destructible<T>::value, "raw bytes of the capacity are written");
  if (capacity <= vector->capacity()) return;
  vector->reserve(capacity);
  touchPagesInParallel(vector->data() + vector->size(), (vector->capacity() - vector->size()) * sizeof(T));
}

}  // namespace amhmvs
