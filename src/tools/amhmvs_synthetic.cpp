// amhmvs_synthetic: writes a built-in synthetic scene as an MVSNet dense
// folder (images/, cams/, pair.txt) with exact ground-truth depth
// (depth_gt/NNNNNNNN.pfm), for the demo and for users without data.
//
// usage: amhmvs_synthetic OUTPUT_DIR [--scene room|folded] [--views N]
//                         [--width W] [--height H] [--seed S]
//                         [--realism none|default] [--frame_period S] [effect options]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/simulation/realistic_capture.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "synthetic_problem.h"
#include "synthetic_realism_report.h"
#include "tool_options.h"

namespace amhmvs {
namespace {

const char* kUsageHead =
    "Usage: amhmvs_synthetic OUTPUT_DIR [--scene room|folded] [--views N] [--width W]\n"
    "                        [--height H] [--seed S] [--realism none|default]\n"
    "                        [--frame_period S] [realism options]\n\n"
    "Renders a built-in textured scene (no data needed) and writes it as an MVSNet\n"
    "dense folder: images/NNNNNNNN.png, cams/NNNNNNNN_cam.txt (depth range from the\n"
    "true depth, widened 10 %), pair.txt (sources ranked by triangulation angle) and\n"
    "depth_gt/NNNNNNNN.pfm (exact z-depth, metres, NaN where nothing is hit).\n"
    "  --scene room    an indoor room (walls, floor, boxes, ramp, sphere, a weakly\n"
    "                  textured wall) along a smooth trajectory (default)\n"
    "  --scene folded  three slanted textured planes meeting along creases, seen\n"
    "                  from sideways-moving cameras\n"
    "  --views N (default 8)  --width W (320)  --height H (240)  --seed S (1)\n\n"
    "Realism: what a real camera behind a real tracker delivers, ground truth exact.\n"
    "  --realism none     the exact render (default)\n"
    "  --realism default  a handheld camera behind a VIO tracker: the values below\n"
    "                     marked [default profile]\n"
    "  --frame_period S   seconds between frames (0.5): the time base of the effects\n"
    "Each effect alone (after --realism, whatever the order):\n";
const char* kUsageTail =
    "With realism, cams/ holds the tracker's (written) poses, cams_gt/ the true poses\n"
    "(middle row at mid exposure), depth_gt/ the true depth of what each pixel saw, and\n"
    "realism.txt the options and per frame what they did (in pixels of image motion).\n";

std::string usage() {
  const RealismOptions profile = realismProfile("default");
  std::string options;
  for (const RealismOptionInfo& info : realismOptionTable()) {
    options += "  --" + info.name + " (" + info.get(RealismOptions()) + "; [default profile] " + info.get(profile) +
               ")\n      " + info.help + "\n";
  }
  return kUsageHead + options + kUsageTail;
}

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

struct SyntheticOptions {
  std::string scene = "room";
  int views = 8, width = 320, height = 240;
  uint32_t seed = 1;
  double frame_period = 0.5;
  RealismOptions realism;  // seed: --realism_seed, else --seed
};

SyntheticOptions parseOptions(const std::vector<std::string>& args) {
  SyntheticOptions o;
  // The profile first, so that single effects override it in any order.
  std::vector<std::pair<std::string, std::string>> options;
  for (size_t i = 1; i < args.size(); ++i) {
    std::string name, value;
    nextOption(args, &i, {}, &name, &value);
    if (name == "realism") o.realism = realismProfile(value);
    else options.push_back({name, value});
  }
  bool realism_seed_given = false;
  for (const auto& [name, value] : options) {
    if (name == "scene") o.scene = value;
    else if (name == "views") o.views = parseValue<int>(name, value);
    else if (name == "width") o.width = parseValue<int>(name, value);
    else if (name == "height") o.height = parseValue<int>(name, value);
    else if (name == "seed") o.seed = parseValue<uint32_t>(name, value);
    else if (name == "frame_period") o.frame_period = parseValue<double>(name, value);
    else if (setOptionFromTable(realismOptionTable(), name, value, &o.realism)) realism_seed_given |= name == "realism_seed";
    else throw InputError("unknown option --" + name + " (see --help)");
  }
  if (o.views < 2 || o.views > 1000) throw InputError("--views must be in 2..1000");
  if (o.width < 16 || o.height < 16 || o.width > 8192 || o.height > 8192) {
    throw InputError("--width and --height must be in 16..8192");
  }
  if (!(o.frame_period > 0 && o.frame_period <= 3600)) throw InputError("--frame_period must be in (0, 3600] seconds");
  if (!realism_seed_given) o.realism.seed = o.seed;
  const std::string problems = o.realism.check();
  if (!problems.empty()) throw InputError("invalid realism options:\n" + problems);
  return o;
}

int run(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << usage();
    return args.empty() ? 2 : 0;
  }
  const std::string out = args[0];
  const SyntheticOptions o = parseOptions(args);
  const RealismOptions& realism = o.realism;
  const int views = o.views;
  SyntheticWorld world;
  CameraTrajectory trajectory;
  if (o.scene == "room") {
    world = makeIndoorRoomWorld(o.seed);
    trajectory = smoothRoomTrajectory(views, o.width, o.height, o.seed, o.frame_period);
  } else if (o.scene == "folded") {
    world = makeFoldedPlanesWorld(o.seed);
    trajectory = interpolatedTrajectory(makeSidewaysCameras(views, o.width, o.height), o.frame_period);
  } else {
    throw InputError("--scene must be room or folded");
  }
  const std::vector<FrameDisturbance> disturbances = drawFrameDisturbances(realism, views, o.frame_period);
  namespace fs = std::filesystem;
  std::vector<const char*> folders = {"images", "cams", "depth_gt"};
  if (realism.any()) folders.push_back("cams_gt");
  for (const char* sub : folders) fs::create_directories(fs::path(out) / sub);
  std::vector<double> medians;
  std::vector<PinholeCamera> cameras;  // as written: the tracker's
  std::vector<FrameRealismReport> reports;
  for (int v = 0; v < views; ++v) {
    // With realism none this is renderView at the trajectory's view, bit for bit.
    const RenderedView view = renderRealisticView(world, trajectory, v, realism, disturbances[v]);
    cameras.push_back(trackedCamera(trajectory(v, 0), disturbances[v]));
    char name[32];
    std::snprintf(name, sizeof(name), "%08d", v);
    writePng(out + "/images/" + name + ".png", view.image);
    writePfm(out + "/depth_gt/" + name + ".pfm", view.depth);
    float lo = INFINITY, hi = 0;
    for (float d : view.depth.data) {
      if (std::isfinite(d)) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    writeMvsnetCam(out + "/cams/" + name + "_cam.txt", cameras.back(), 0.9 * lo, 1.1 * hi);
    if (realism.any()) {
      writeMvsnetCam(out + "/cams_gt/" + name + "_cam.txt", view.camera, 0.9 * lo, 1.1 * hi);
      reports.push_back(reportFrame(view, cameras.back(), trajectory, v, realism, disturbances[v]));
    }
    medians.push_back(medianFinite(view.depth));
    std::fprintf(stderr, "\rrendered %d/%d views", v + 1, views);
  }
  std::string pair = std::to_string(views) + "\n";
  char entry[64];
  for (int r = 0; r < views; ++r) {
    std::vector<std::pair<double, int>> ranked;
    for (int s = 0; s < views; ++s) {
      if (s != r) ranked.push_back({-pairScore(cameras[r], medians[r], cameras[s]), s});
    }
    std::sort(ranked.begin(), ranked.end());
    const size_t keep = std::min<size_t>(ranked.size(), 10);
    pair += std::to_string(r) + "\n" + std::to_string(keep);
    for (size_t k = 0; k < keep; ++k) {
      std::snprintf(entry, sizeof(entry), " %d %.6f", ranked[k].second, -ranked[k].first);
      pair += entry;
    }
    pair += "\n";
  }
  writeFileAtomically(out + "/pair.txt", pair, "view pairs");
  std::fprintf(stderr, "\nwrote %s (%d views, %dx%d, scene %s)\n", out.c_str(), views, o.width, o.height,
               o.scene.c_str());
  if (realism.any()) {
    writeRealismReport(out + "/realism.txt", realism, o.frame_period, reports);
    std::fprintf(stderr, "%s\n", summarizeRealism(reports).c_str());
  }
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
