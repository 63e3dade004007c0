// amhmvs_cloud_metrics: accuracy, completeness and F1 of a point cloud against
// a ground-truth cloud or ground-truth depth maps. See --help.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "tool_options.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "tool_main.h"

namespace {

namespace fs = std::filesystem;
using amhmvs::InputError;

const char* kUsage =
    "Usage: amhmvs_cloud_metrics CLOUD.ply (--gt_cloud GT.ply | --gt_depth_dir DIR --cams "
    "DENSE_DIR)\n"
    "                            [--thresholds 0.01,0.02,0.05] [--stride N]\n"
    "\n"
    "Prints accuracy (share of CLOUD's points within t of the ground truth), completeness\n"
    "(share of ground-truth points within t of CLOUD) and their F1 per threshold t (metres).\n"
    "The ground truth is a PLY cloud, or the z-depth maps DIR/NNNNNNNN.pfm back-projected\n"
    "with the cameras of the MVSNet dense folder DENSE_DIR (rescaled to each map's size),\n"
    "every N-th pixel in x and y (--stride, default 1).\n";

std::vector<double> parseThresholds(const std::string& text) {
  std::vector<double> thresholds;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double t = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !(std::isfinite(t) && t > 0)) {
      throw InputError("option --thresholds: '" + item + "' is not a positive number");
    }
    thresholds.push_back(t);
  }
  if (thresholds.empty()) throw InputError("option --thresholds: empty list");
  return thresholds;
}

std::vector<Eigen::Vector3f> groundTruthFromDepth(const std::string& depth_dir,
                                                  const std::string& dense_dir, int stride) {
  if (!fs::is_directory(depth_dir)) throw InputError(depth_dir + ": folder not found");
  const amhmvs::Scene scene = amhmvs::readMvsnetDenseFolder(dense_dir);
  std::vector<amhmvs::DepthMapView> views;
  for (const amhmvs::SceneView& v : scene.views) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%08d.pfm", v.id);
    const std::string path = depth_dir + name;
    if (!fs::exists(path)) continue;
    views.push_back({v.camera, amhmvs::readPfm(path)});
  }
  if (views.empty()) {
    throw InputError(depth_dir + ": no ground-truth depth map NNNNNNNN.pfm for the views of " +
                     dense_dir);
  }
  std::cout << "ground truth: " << views.size() << " depth maps\n";
  return amhmvs::backprojectDepthMaps(views, stride);
}

int run(const std::vector<std::string>& args) {
  std::string gt_cloud, gt_depth_dir, cams;
  std::vector<double> thresholds = {0.01, 0.02, 0.05};
  int stride = 1;
  for (size_t i = 1; i < args.size(); ++i) {
    std::string name, value;
    amhmvs::nextOption(args, &i, {}, &name, &value);
    if (name == "gt_cloud") {
      gt_cloud = value;
    } else if (name == "gt_depth_dir") {
      gt_depth_dir = value;
    } else if (name == "cams") {
      cams = value;
    } else if (name == "thresholds") {
      thresholds = parseThresholds(value);
    } else if (name == "stride") {
      stride = amhmvs::parseValue<int>(name, value);
      if (stride < 1 || stride > 100000) throw InputError("option --stride: '" + value + "' is not in 1..100000");
    } else {
      throw InputError("unknown option --" + name + " (see --help)");
    }
  }
  if (gt_cloud.empty() == gt_depth_dir.empty()) {
    throw InputError("give exactly one of --gt_cloud and --gt_depth_dir");
  }
  if (!gt_depth_dir.empty() && cams.empty()) throw InputError("--gt_depth_dir needs --cams");

  const amhmvs::PointCloud cloud = amhmvs::readPly(args[0]);
  const std::vector<Eigen::Vector3f> ground_truth =
      gt_cloud.empty() ? groundTruthFromDepth(gt_depth_dir, cams, stride)
                       : amhmvs::readPly(gt_cloud).points;
  const amhmvs::CloudMetrics metrics =
      amhmvs::evaluateCloud(cloud.points, ground_truth, thresholds);
  std::cout << metrics.table();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return amhmvs::runToolMain("amhmvs_cloud_metrics", kUsage, argc, argv, 1, true, run);
}
