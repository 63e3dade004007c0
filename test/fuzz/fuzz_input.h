// Shared by the libFuzzer targets of test/fuzz: the readers take file paths,
// so each input is written to a per-process scratch file (or folder); a reader
// may throw InputError (bad input, refused) and nothing else: any other
// exception, a crash, a sanitizer report or a leak is a finding.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "../common/temp_dir.h"

namespace amhmvs {
namespace fuzz {

// This process's scratch folder, created once and removed when it exits
// (every run used to leave one behind).
inline std::string scratchDir() {
  static const test::TempDir dir("amhmvs_fuzz_");
  return dir.path();
}

// Writes bytes to scratchDir()/name (creating parent folders) and returns the path.
inline std::string writeScratch(const std::string& name, const uint8_t* data, size_t size) {
  return test::TempDir::writeTo(scratchDir() + "/" + name, std::string(reinterpret_cast<const char*>(data), size));
}

// Splits an input into `parts` pieces at the separator line "\n--8<--\n"
// (the seed script joins the files of a multi-file format with it); missing
// pieces are empty.
inline std::vector<std::string> splitParts(const uint8_t* data, size_t size, size_t parts) {
  static const std::string kSeparator = "\n--8<--\n";
  const std::string all(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> out;
  size_t pos = 0;
  while (out.size() + 1 < parts) {
    const size_t cut = all.find(kSeparator, pos);
    if (cut == std::string::npos) break;
    out.push_back(all.substr(pos, cut - pos));
    pos = cut + kSeparator.size();
  }
  out.push_back(all.substr(std::min(pos, all.size())));
  out.resize(parts);
  return out;
}

// Runs a reader: InputError is the refusal the readers promise; any other
// exception aborts, which libFuzzer reports as a crash with this input.
template <typename Read>
void expectOnlyInputErrors(Read read) {
  try {
    read();
  } catch (const InputError&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader threw %s instead of InputError\n", e.what());
    std::abort();
  }
}

}  // namespace fuzz
}  // namespace amhmvs
