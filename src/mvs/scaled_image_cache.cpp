#include "amhmvs_mapping/mvs/scaled_image_cache.h"

namespace amhmvs {
namespace mvs {

ScaledImageCache::Scaled ScaledImageCache::get(const ImageViewU8& image, int64_t key, int width, int height) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Copy>& copies = copies_[key];
  for (const Copy& copy : copies) {
    if (copy.width == width && copy.height == height) return {*copy.image, copy.key};
  }
  copies.push_back({width, height, next_key_++, std::make_unique<ImageU8>(resizeArea(image, width, height))});
  return {*copies.back().image, copies.back().key};
}

std::vector<int64_t> ScaledImageCache::forget(int64_t key) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<int64_t> keys;
  const auto found = copies_.find(key);
  if (found == copies_.end()) return keys;
  for (const Copy& copy : found->second) keys.push_back(copy.key);
  copies_.erase(found);
  return keys;
}

void ScaledImageCache::forgetAll() {
  const std::lock_guard<std::mutex> lock(mutex_);
  copies_.clear();
}

size_t ScaledImageCache::bytes() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  size_t total = 0;
  for (const auto& entry : copies_) {
    for (const Copy& copy : entry.second) total += copy.image->data.size();
  }
  return total;
}

}  // namespace mvs
}  // namespace amhmvs
