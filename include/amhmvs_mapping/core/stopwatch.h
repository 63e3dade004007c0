// Wall-clock milliseconds on the steady clock, for stage times and reports.
#pragma once

#include <chrono>

namespace amhmvs {

inline double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace amhmvs
