// libFuzzer target: readPly on arbitrary bytes; an accepted cloud must be
// consistent (PointCloud::validate). There is no PCD reader (PCD is written only).
#include <cstdlib>

#include "amhmvs_mapping/io/point_cloud_io.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = amhmvs::fuzz::writeScratch("input.ply", data, size);
  amhmvs::fuzz::expectOnlyInputErrors([&] {
    if (!amhmvs::readPly(path).validate().empty()) std::abort();
  });
  return 0;
}
