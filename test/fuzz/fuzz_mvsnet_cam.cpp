// libFuzzer target: readMvsnetCam on arbitrary bytes; an accepted camera must
// have the finite, positive depth range the reader promises.
#include <cmath>

#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = amhmvs::fuzz::writeScratch("input_cam.txt", data, size);
  amhmvs::fuzz::expectOnlyInputErrors([&] {
    amhmvs::PinholeCamera camera;
    double depth_min = 0, depth_max = 0;
    amhmvs::readMvsnetCam(path, &camera, &depth_min, &depth_max);
    if (!(std::isfinite(depth_max) && depth_min > 0 && depth_max > depth_min)) std::abort();
  });
  return 0;
}
