// An immutable value shared by everyone who holds it: a keyframe's depth map
// and fused points are made once and then read by the keyframe store, the
// result that reports them and the voxel map, without a copy each (at
// 640x480 a copy is 6-8 MB of fresh memory, milliseconds of page faults).
//
//   Shared<KeyframePoints> points(std::move(fused));  // takes the value (a move)
//   store.attachPoints(id, points);                    // shares it
//   for (const KeyframePoint& p : *points) ...
//   const KeyframePoints& view = points;              // borrows it
//
// Never null: a default Shared holds a default-constructed value.
#pragma once

#include <memory>
#include <utility>

namespace amhmvs {

template <typename T>
class Shared {
 public:
  Shared() : value_(empty()) {}
  // Implicit, so that a value can be handed where a Shared is taken (moved
  // when it is an rvalue).
  Shared(T value) : value_(std::make_shared<const T>(std::move(value))) {}  // NOLINT(runtime/explicit)

  const T& operator*() const { return *value_; }
  const T* operator->() const { return value_.get(); }
  // Borrowed where a const T& is expected.
  operator const T&() const { return *value_; }

  // Whether two holders share one value (tests: no copy was made).
  bool sameValue(const Shared& other) const { return value_ == other.value_; }

 private:
  // One empty value for every default Shared<T>: no allocation per default.
  static const std::shared_ptr<const T>& empty() {
    static const std::shared_ptr<const T> value = std::make_shared<const T>();
    return value;
  }
  std::shared_ptr<const T> value_;
};

}  // namespace amhmvs
