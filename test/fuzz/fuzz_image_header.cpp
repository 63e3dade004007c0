// libFuzzer target: the image header readers (PNG IHDR, JPEG SOFn, BMP, PGM/PPM)
// of readImageSize, and the native PGM/PPM decoder of readImage. Compressed
// pixel data is decoded by OpenCV, which is not ours to fuzz here.
#include <cstring>

#include "amhmvs_mapping/io/image_io.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = amhmvs::fuzz::writeScratch("input.img", data, size);
  amhmvs::fuzz::expectOnlyInputErrors([&] {
    int width = 0, height = 0;
    if (amhmvs::readImageSize(path, &width, &height) &&
        (width <= 0 || height <= 0 || width > amhmvs::kMaxImageSide ||
         height > amhmvs::kMaxImageSide)) {
      std::abort();  // a size outside the documented range was accepted
    }
  });
  if (size >= 2 && data[0] == 'P') {
    amhmvs::fuzz::expectOnlyInputErrors([&] { amhmvs::readImage(path); });
  }
  return 0;
}
