// The command-line convention shared by the amhmvs tools: --help prints the
// usage and exits 0; too few arguments (or an option where the first path is
// expected) print the usage and exit 2; bad input exits 1 with
// "<name>: error: <message>"; any other failure exits 3.
#pragma once

#include <exception>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

inline int runToolMain(const char* name, const std::string& usage, int argc, char** argv,
                       size_t min_arguments, bool first_argument_is_a_path,
                       const std::function<int(const std::vector<std::string>&)>& run) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << usage;
      return 0;
    }
  }
  if (args.size() < min_arguments ||
      (first_argument_is_a_path && !args.empty() && args[0].rfind("--", 0) == 0)) {
    std::cerr << usage;
    return 2;
  }
  try {
    return run(args);
  } catch (const InputError& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << name << ": failed: " << e.what() << "\n";
    return 3;
  }
}

}  // namespace amhmvs
