#include "amhmvs_mapping/core/fresh_memory.h"

namespace amhmvs {

void touchPagesInParallel(void* data, size_t bytes) {
  constexpr size_t kPage = 4096;
  // Below this one thread faults about as fast as a team starts.
  constexpr size_t kWorthIt = size_t{1} << 20;
  if (bytes < kWorthIt) return;
  volatile char* const begin = static_cast<char*>(data);
  const long pages = static_cast<long>(bytes / kPage);
  // One byte in every page of the range (each step of a page lands in the next one).
#pragma omp parallel for schedule(static)
  for (long page = 0; page < pages; ++page) begin[static_cast<size_t>(page) * kPage] = 0;
  begin[bytes - 1] = 0;
}

}  // namespace amhmvs
