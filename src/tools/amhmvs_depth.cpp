// amhmvs_depth: offline AMHMVS depth maps for an MVSNet dense folder or a
// COLMAP workspace. See --help.
#include <iostream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "depth_job.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << amhmvs::depthJobUsage();
      return 0;
    }
  }
  if (args.size() < 2) {
    std::cerr << amhmvs::depthJobUsage();
    return 2;
  }
  try {
    const amhmvs::DepthJobOptions options =
        amhmvs::parseDepthJobArguments(std::vector<std::string>(args.begin() + 2, args.end()));
    amhmvs::runDepthJob(args[0], args[1], options);
  } catch (const amhmvs::InputError& e) {
    std::cerr << "amhmvs_depth: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "amhmvs_depth: failed: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
