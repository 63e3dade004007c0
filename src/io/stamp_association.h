// Internal to src/io: pairing stamped entries (images, depth maps, poses) by
// the nearest stamp within a tolerance, as TUM RGB-D's tools do.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace amhmvs {
namespace internal {

struct Stamped {
  double stamp;
  size_t index;  // into the file's own list
};

// Stamps sorted, for nearest-neighbour association.
template <typename T>
inline std::vector<Stamped> sortedStamps(const std::vector<std::pair<double, T>>& entries) {
  std::vector<Stamped> stamps;
  for (size_t i = 0; i < entries.size(); ++i) stamps.push_back({entries[i].first, i});
  std::sort(stamps.begin(), stamps.end(), [](const Stamped& a, const Stamped& b) { return a.stamp < b.stamp; });
  return stamps;
}

// Index of the entry nearest to `stamp` within `tolerance`, or -1.
inline long nearest(const std::vector<Stamped>& stamps, double stamp, double tolerance) {
  const auto after = std::lower_bound(stamps.begin(), stamps.end(), stamp,
                                      [](const Stamped& s, double t) { return s.stamp < t; });
  long best = -1;
  double best_gap = tolerance;
  for (auto it : {after, after - (after == stamps.begin() ? 0 : 1)}) {
    if (it == stamps.end()) continue;
    const double gap = std::abs(it->stamp - stamp);
    if (gap <= best_gap) best_gap = gap, best = static_cast<long>(it->index);
  }
  return best;
}

}  // namespace internal
}  // namespace amhmvs
