// amhmvs_synthetic: writes a built-in synthetic scene as an MVSNet dense
// folder (images/, cams/, pair.txt) with exact ground-truth depth
// (depth_gt/NNNNNNNN.pfm), for the demo and for users without data.
//
// usage: amhmvs_synthetic OUTPUT_DIR [--scene room|folded] [--views N]
//                         [--width W] [--height H] [--seed S]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/synthetic_scene.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "synthetic_problem.h"
#include "tool_options.h"

namespace amhmvs {
namespace {

const char* kUsage =
    "Usage: amhmvs_synthetic OUTPUT_DIR [--scene room|folded] [--views N] [--width W]\n"
    "                        [--height H] [--seed S]\n\n"
    "Renders a built-in textured scene (no data needed) and writes it as an MVSNet\n"
    "dense folder: images/NNNNNNNN.png, cams/NNNNNNNN_cam.txt (depth range from the\n"
    "true depth, widened 10 %), pair.txt (sources ranked by triangulation angle) and\n"
    "depth_gt/NNNNNNNN.pfm (exact z-depth, metres, NaN where nothing is hit).\n"
    "  --scene room    an indoor room (walls, floor, boxes, ramp, sphere, a weakly\n"
    "                  textured wall) along a smooth trajectory (default)\n"
    "  --scene folded  three slanted textured planes meeting along creases, seen\n"
    "                  from sideways-moving cameras\n"
    "  --views N (default 8)  --width W (320)  --height H (240)  --seed S (1)\n";

// MVSNet-style score of a source for a reference: a Gaussian of the
// triangulation angle at the reference's median scene point, peaking at 5 deg.
double pairScore(const PinholeCamera& ref, double median_depth, const PinholeCamera& src) {
  const Eigen::Vector3d point = ref.center() + median_depth * ref.viewingDirection();
  const double theta = triangulationAngle(ref.center(), src.center(), point) * 180.0 / M_PI;
  const double sigma = theta <= 5.0 ? 1.0 : 10.0;
  return std::exp(-(theta - 5.0) * (theta - 5.0) / (2 * sigma * sigma));
}

double medianFinite(const ImageF& image) {
  std::vector<float> values;
  for (float v : image.data) {
    if (std::isfinite(v)) values.push_back(v);
  }
  if (values.empty()) throw InputError("a rendered view sees nothing");
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

int run(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  const std::string out = args[0];
  std::string scene = "room";
  int views = 8, width = 320, height = 240;
  uint32_t seed = 1;
  for (size_t i = 1; i < args.size(); ++i) {
    std::string name, value;
    nextOption(args, &i, {}, &name, &value);
    if (name == "scene") scene = value;
    else if (name == "views") views = parseValue<int>(name, value);
    else if (name == "width") width = parseValue<int>(name, value);
    else if (name == "height") height = parseValue<int>(name, value);
    else if (name == "seed") seed = parseValue<uint32_t>(name, value);
    else throw InputError("unknown option --" + name + " (see --help)");
  }
  if (views < 2 || views > 1000) throw InputError("--views must be in 2..1000");
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    throw InputError("--width and --height must be in 16..8192");
  }
  SyntheticWorld world;
  std::vector<PinholeCamera> cameras;
  if (scene == "room") {
    world = makeIndoorRoomWorld(seed);
    cameras = makeSmoothTrajectory(views, width, height, seed);
  } else if (scene == "folded") {
    world = makeFoldedPlanesWorld(seed);
    cameras = makeSidewaysCameras(views, width, height);
  } else {
    throw InputError("--scene must be room or folded");
  }
  namespace fs = std::filesystem;
  for (const char* sub : {"images", "cams", "depth_gt"}) fs::create_directories(fs::path(out) / sub);
  std::vector<double> medians;
  for (int v = 0; v < views; ++v) {
    const RenderedView view = renderView(world, cameras[v]);
    char name[32];
    std::snprintf(name, sizeof(name), "%08d", v);
    writePng(out + "/images/" + name + ".png", view.image);
    writePfm(out + "/depth_gt/" + name + ".pfm", view.depth);
    float lo = INFINITY, hi = 0;
    for (float d : view.depth.data) {
      if (std::isfinite(d)) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    writeMvsnetCam(out + "/cams/" + name + "_cam.txt", view.camera, 0.9 * lo, 1.1 * hi);
    medians.push_back(medianFinite(view.depth));
    std::fprintf(stderr, "\rrendered %d/%d views", v + 1, views);
  }
  std::FILE* pair = std::fopen((out + "/pair.txt").c_str(), "w");
  if (!pair) throw InputError(out + "/pair.txt: cannot write");
  std::fprintf(pair, "%d\n", views);
  for (int r = 0; r < views; ++r) {
    std::vector<std::pair<double, int>> ranked;
    for (int s = 0; s < views; ++s) {
      if (s != r) ranked.push_back({-pairScore(cameras[r], medians[r], cameras[s]), s});
    }
    std::sort(ranked.begin(), ranked.end());
    const size_t keep = std::min<size_t>(ranked.size(), 10);
    std::fprintf(pair, "%d\n%zu", r, keep);
    for (size_t k = 0; k < keep; ++k) std::fprintf(pair, " %d %.6f", ranked[k].second, -ranked[k].first);
    std::fprintf(pair, "\n");
  }
  std::fclose(pair);
  std::fprintf(stderr, "\nwrote %s (%d views, %dx%d, scene %s)\n", out.c_str(), views, width, height,
               scene.c_str());
  return 0;
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  try {
    return amhmvs::run(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::cerr << "amhmvs_synthetic: error: " << e.what() << "\n";
    return 1;
  }
}
