// amhmvs_depth: offline AMHMVS depth maps for an MVSNet dense folder or a
// COLMAP workspace. See --help.
#include <iostream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "depth_job.h"
#include "tool_main.h"

int main(int argc, char** argv) {
  return amhmvs::runToolMain(
      "amhmvs_depth", amhmvs::depthJobUsage(), argc, argv, 2, false,
      [](const std::vector<std::string>& args) {
        const amhmvs::DepthJobOptions options =
            amhmvs::parseDepthJobArguments(std::vector<std::string>(args.begin() + 2, args.end()));
        amhmvs::runDepthJob(args[0], args[1], options);
        return 0;
      });
}
