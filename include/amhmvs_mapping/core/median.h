// Median of a non-empty sample (the mean of the two middle values for an even
// count), in O(n).
#pragma once

#include <algorithm>
#include <vector>

namespace amhmvs {

inline double medianOf(std::vector<double> values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

}  // namespace amhmvs
