// Coarser copies of keyed images, made once. A coarse-to-fine estimate
// (coarse_to_fine.h) needs every image of its problem at each coarser scale;
// an online mapper uses a keyframe's image as a source again and again, so
// its copies are kept (per key and size) until the owner forgets the key, as
// it forgets the image itself (DepthEstimator::forget). Each copy has a key
// of its own, so that a backend that keeps keyed images resident (CUDA)
// uploads it once too. Thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "amhmvs_mapping/core/image.h"

namespace amhmvs {
namespace mvs {

// Keys of the copies count up from here: keys of callers' images must lie
// above it (DepthProblem::validate says so).
constexpr int64_t kScaledImageKeyBase = INT64_MIN / 2;

class ScaledImageCache {
 public:
  struct Scaled {
    ImageViewU8 image;  // valid until forget(key) or forgetAll()
    int64_t key;        // the copy's own key
  };
  // The image of `key` area-downsampled to width x height (resizeArea),
  // made on the first call.
  Scaled get(const ImageViewU8& image, int64_t key, int width, int height);
  // Drops the copies of `key` (all of them); returns their keys.
  std::vector<int64_t> forget(int64_t key);
  void forgetAll();
  size_t bytes() const;

 private:
  struct Copy {
    int width, height;
    int64_t key;
    std::unique_ptr<ImageU8> image;  // a stable address while the map changes
  };
  mutable std::mutex mutex_;
  std::map<int64_t, std::vector<Copy>> copies_;
  int64_t next_key_ = kScaledImageKeyBase;
};

}  // namespace mvs
}  // namespace amhmvs
