// amhmvs_fuse: fuses the depth maps written by amhmvs_depth into one point
// cloud (PLY or PCD). See --help.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "tool_main.h"

namespace {

namespace fs = std::filesystem;
using amhmvs::InputError;

const char* kUsage =
    "Usage: amhmvs_fuse DENSE_DIR DEPTH_DIR OUTPUT.(ply|pcd) [options]\n"
    "\n"
    "Fuses depth and normal maps into one point cloud by a multi-view consistency check.\n"
    "DENSE_DIR is the MVSNet dense folder the depth maps were made from (pair.txt gives each\n"
    "view's sources, images/ the colours); DEPTH_DIR holds amhmvs_depth's output,\n"
    "<8-digit id>/{depth.pfm, normal.pfm, cam.txt[, cost.pfm]}. Views without a depth map\n"
    "are left out, also as sources. Writes binary PLY (x y z nx ny nz red green blue\n"
    "quality) or binary PCD (x y z rgb normal_x normal_y normal_z) by extension.\n"
    "\n"
    "Options (a threshold of 'inf' switches its check off):\n"
    "  --preset paper|reprojection   paper: disparity 0.3 px, normals 30 deg, 2 views (default)\n"
    "                                reprojection: 2 px, 1 % depth, 10 deg, 2 views\n"
    "  --disparity_threshold F       disparity difference in pixels, f * baseline / depth\n"
    "  --normal_threshold DEG        normal angle in degrees\n"
    "  --reprojection_threshold PX   reprojection error into the reference, pixels\n"
    "  --depth_threshold REL         relative depth difference in the reference\n"
    "  --min_consistent N            agreeing source views needed\n"
    "  --max_sources N               first N sources of pair.txt per view (0 = all)\n"
    "  --max_cost C                  ignore pixels whose cost exceeds C (needs cost.pfm)\n"
    "  --keep_duplicates             fuse every view on its own (no used-pixel mask)\n";

std::string viewFolder(const std::string& depth_dir, int id) {
  char name[16];
  std::snprintf(name, sizeof(name), "%08d", id);
  return depth_dir + "/" + name;
}

double parseNumber(const std::string& option, const std::string& value) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || std::isnan(v)) {
    throw InputError("option " + option + ": '" + value + "' is not a number");
  }
  return v;
}

int parseCount(const std::string& option, const std::string& value) {
  const double v = parseNumber(option, value);
  if (v != std::floor(v) || v < 0 || v > 1e6) {
    throw InputError("option " + option + ": '" + value + "' is not a non-negative integer");
  }
  return static_cast<int>(v);
}

amhmvs::FusionOptions parseOptions(const std::vector<std::string>& args) {
  // The preset first, so that single thresholds override it in any order.
  amhmvs::FusionOptions options = amhmvs::FusionOptions::paper();
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] != "--preset") continue;
    if (args[i + 1] == "paper") {
      options = amhmvs::FusionOptions::paper();
    } else if (args[i + 1] == "reprojection" || args[i + 1] == "colmap") {
      options = amhmvs::FusionOptions::reprojection();
    } else {
      throw InputError("option --preset: unknown preset '" + args[i + 1] +
                       "' (paper or reprojection)");
    }
  }
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--keep_duplicates") {
      options.fuse_each_pixel_once = false;
      continue;
    }
    if (a.rfind("--", 0) != 0) throw InputError("unexpected argument '" + a + "'");
    if (i + 1 >= args.size()) throw InputError("option " + a + " needs a value");
    const std::string& value = args[++i];
    if (a == "--preset") {
      // handled above
    } else if (a == "--disparity_threshold") {
      options.max_disparity_difference = static_cast<float>(parseNumber(a, value));
    } else if (a == "--normal_threshold") {
      options.max_normal_angle_deg = static_cast<float>(parseNumber(a, value));
    } else if (a == "--reprojection_threshold") {
      options.max_reprojection_error = static_cast<float>(parseNumber(a, value));
    } else if (a == "--depth_threshold") {
      options.max_relative_depth_difference = static_cast<float>(parseNumber(a, value));
    } else if (a == "--max_cost") {
      options.max_cost = static_cast<float>(parseNumber(a, value));
    } else if (a == "--min_consistent") {
      options.min_consistent_views = parseCount(a, value);
    } else if (a == "--max_sources") {
      options.max_sources = parseCount(a, value);
    } else {
      throw InputError("unknown option " + a + " (see --help)");
    }
  }
  const std::string why = options.validate();
  if (!why.empty()) throw InputError("fusion options: " + why);
  return options;
}

// One view's depth output as read from its folder.
struct DepthView {
  int id = -1;
  amhmvs::PinholeCamera camera;
  amhmvs::DepthMapImages images;
};

// Reads one view's depth output; false when the view has no depth map.
bool readDepthView(const std::string& depth_dir, const amhmvs::SceneView& scene_view, DepthView* view,
                   bool* color_warned) {
  const std::string folder = viewFolder(depth_dir, scene_view.id);
  if (!fs::exists(folder + "/depth.pfm")) return false;
  view->id = scene_view.id;
  amhmvs::DepthMapImages& images = view->images;
  images.depth = amhmvs::readPfm(folder + "/depth.pfm");
  images.normal = amhmvs::readPfm(folder + "/normal.pfm");
  if (fs::exists(folder + "/cost.pfm")) images.cost = amhmvs::readPfm(folder + "/cost.pfm");
  double depth_min, depth_max;
  amhmvs::readMvsnetCam(folder + "/cam.txt", &view->camera, &depth_min, &depth_max);
  // cam.txt holds the camera at the depth map's resolution, without the size.
  view->camera.width = images.depth.width;
  view->camera.height = images.depth.height;
  try {
    amhmvs::ImageU8 image = amhmvs::readImage(scene_view.image_path);
    if (!image.sameSize(images.depth.width, images.depth.height)) {
      image = amhmvs::resizeArea(image, images.depth.width, images.depth.height);
    }
    images.color = std::move(image);
  } catch (const InputError& e) {
    // Colour is a nicety: fuse without it rather than fail.
    if (!*color_warned) std::cerr << "amhmvs_fuse: warning: no colours: " << e.what() << "\n";
    *color_warned = true;
  }
  return true;
}

int run(const std::vector<std::string>& args) {
  const std::string dense_dir = args[0], depth_dir = args[1], output = args[2];
  const amhmvs::FusionOptions options =
      parseOptions(std::vector<std::string>(args.begin() + 3, args.end()));
  {
    std::string ext = fs::path(output).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".ply" && ext != ".pcd") {
      throw InputError(output + ": output must end in .ply or .pcd");
    }
  }
  if (!fs::is_directory(depth_dir)) throw InputError(depth_dir + ": depth folder not found");
  const amhmvs::Scene scene = amhmvs::readMvsnetDenseFolder(dense_dir);

  std::vector<DepthView> read;  // owns the images the fusion views borrow
  bool color_warned = false;
  for (const amhmvs::SceneView& scene_view : scene.views) {
    DepthView view;
    if (readDepthView(depth_dir, scene_view, &view, &color_warned)) read.push_back(std::move(view));
  }
  std::vector<amhmvs::FusionView> views;
  for (const DepthView& view : read) views.push_back(view.images.borrow(view.id, view.camera));
  if (views.empty()) {
    throw InputError(depth_dir + ": no depth maps (<8-digit id>/depth.pfm) for the views of " +
                     dense_dir);
  }
  std::map<int, bool> has_depth;
  for (const amhmvs::FusionView& v : views) has_depth[v.id] = true;
  for (amhmvs::FusionView& v : views) {
    const auto it = scene.sources.find(v.id);
    if (it == scene.sources.end()) continue;
    for (const amhmvs::SourceCandidate& s : it->second) {
      if (has_depth.count(s.view_id)) v.source_ids.push_back(s.view_id);
    }
  }

  const amhmvs::FusionResult result = amhmvs::fuseDepthMaps(views, options);
  const amhmvs::PointCloud cloud = amhmvs::worldCloud(result);
  amhmvs::writePointCloud(output, cloud);
  for (const amhmvs::FusedViewPoints& v : result.views) {
    std::cout << "view " << v.view_id << ": " << v.points.size() << " points\n";
  }
  std::cout << "amhmvs_fuse: " << views.size() << " depth maps, " << result.candidate_pixels
            << " candidate pixels, " << cloud.size() << " fused points -> " << output << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return amhmvs::runToolMain("amhmvs_fuse", kUsage, argc, argv, 3, false, run);
}
