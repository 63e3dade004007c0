// libFuzzer target: readPfm on arbitrary bytes.
#include "amhmvs_mapping/io/pfm.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = amhmvs::fuzz::writeScratch("input.pfm", data, size);
  amhmvs::fuzz::expectOnlyInputErrors([&] { amhmvs::readPfm(path); });
  return 0;
}
