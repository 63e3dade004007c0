// libFuzzer target: readMvsnetPair on arbitrary bytes.
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = amhmvs::fuzz::writeScratch("pair.txt", data, size);
  amhmvs::fuzz::expectOnlyInputErrors([&] { amhmvs::readMvsnetPair(path); });
  return 0;
}
