// amhmvs_depth: offline AMHMVS depth maps for an MVSNet dense folder or a
// COLMAP workspace. See --help.
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "depth_job.h"
#include "tool_main.h"

int main(int argc, char** argv) {
  amhmvs::preferOneCudaWorkQueue();  // one estimate at a time: one hardware queue is enough
  return amhmvs::runToolMain(
      "amhmvs_depth", amhmvs::depthJobUsage(), argc, argv, 2, false,
      [](const std::vector<std::string>& args) {
        if (args[1].empty()) throw amhmvs::InputError("OUTPUT_DIR is empty: nothing would be written");
        const amhmvs::DepthJobOptions options =
            amhmvs::parseDepthJobArguments(std::vector<std::string>(args.begin() + 2, args.end()));
        // A run whose every depth map is all-invalid wrote useless files: it
        // is an error, not a success.
        size_t valid_pixels = 0, pixels = 0;
        const int maps = amhmvs::runDepthJob(
            args[0], args[1], options,
            [&](int, const amhmvs::DepthProblem&, const amhmvs::DepthMap& map) {
              pixels += map.depth.data.size();
              for (const float d : map.depth.data) valid_pixels += std::isfinite(d) && d > 0;
            });
        if (valid_pixels == 0) {
          throw amhmvs::InputError(
              "no valid depth in any of the " + std::to_string(maps) + " depth maps (" +
              std::to_string(pixels) + " pixels" +
              (options.max_cost > 0 ? ", --max_cost " + std::to_string(options.max_cost)
                                    : "") +
              "): check the cameras, depth ranges and options");
        }
        return 0;
      });
}
