// The next output vector of a hot loop, made on a worker thread while the
// loop waits elsewhere: a vector that is kept afterwards (a keyframe's fused
// points) is fresh memory every time, and constructing it faults once per
// 4 KiB page (2-2.5 ms for a 640x480 keyframe's points on the GPU machine,
// on the critical path, while the CPU sits idle during the next estimate).
//
//   PreparedVector<KeyframePoint> prepared;
//   std::vector<KeyframePoint> out = prepared.take(count, expected_next);
//   ... write out[0..count) ...
#pragma once

#include <algorithm>
#include <cstddef>
#include <functional>
#include <future>
#include <vector>

#include "amhmvs_mapping/core/fresh_memory.h"
#include "amhmvs_mapping/core/serial_worker.h"

namespace amhmvs {

template <typename T>
class PreparedVector {
 public:
  // A vector of `size` default-constructed elements: the prepared one when it
  // is large enough (shrunk to `size`, no element written), else one made
  // now. Then starts preparing the next one, of `next_size` elements.
  std::vector<T> take(size_t size, size_t next_size) {
    std::vector<T> out;
    if (next_.valid()) out = next_.get();  // rethrows what the worker threw (bad_alloc)
    if (out.size() >= size) {
      out.resize(size);
    } else {
      out.clear();
      reserveTouched(&out, size);
      out.resize(size);
    }
    next_ = worker_.submit(std::function<std::vector<T>()>([next_size] { return std::vector<T>(next_size); }));
    return out;
  }

 private:
  SerialWorker worker_;
  std::future<std::vector<T>> next_;
};

}  // namespace amhmvs
