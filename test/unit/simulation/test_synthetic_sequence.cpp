// The synthetic sequence that amhmvs_synthetic writes (the demo's input) has
// self-consistent ground truth: a pixel's true depth, moved into another
// frame with the written cameras, lands on that frame's true depth wherever
// the point is visible in both; and the output depends only on the seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

std::string synthetic(const std::string& out, const std::string& options) {
  const test::CommandResult r =
      test::runCommand(std::string(AMHMVS_TOOLS_DIR) + "/amhmvs_synthetic " + out + " " + options);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return out;
}

std::string viewName(int view) {
  char name[16];
  std::snprintf(name, sizeof(name), "%08d", view);
  return name;
}

// Bilinear interpolation of `depth` at (u, v); NaN when a neighbour is NaN,
// when (u, v) lies outside the pixel centres, or across a depth edge (the four
// neighbours differ by more than 2 %).
double bilinearOffEdges(const ImageF& depth, double u, double v) {
  const int x = static_cast<int>(std::floor(u)), y = static_cast<int>(std::floor(v));
  if (x < 0 || y < 0 || x + 1 >= depth.width || y + 1 >= depth.height) return NAN;
  const float d[4] = {depth.at(x, y), depth.at(x + 1, y), depth.at(x, y + 1), depth.at(x + 1, y + 1)};
  const auto [lo, hi] = std::minmax({d[0], d[1], d[2], d[3]});
  if (!(hi <= 1.02f * lo)) return NAN;
  const double a = u - x, b = v - y;
  return (1 - a) * (1 - b) * d[0] + a * (1 - b) * d[1] + (1 - a) * b * d[2] + a * b * d[3];
}

struct Agreement {
  long visible = 0;   // pixels of A whose point a ray cast from B sees first, off B's depth edges
  long agreeing = 0;  // of those: B's written depth map agrees within 0.5 %
  long behind = 0;    // pixels whose point B's ray passes (it sees something farther)
};

// Moves every pixel of frame `a` into frame `b` with the written cameras.
Agreement projectInto(const std::string& dir, int a, int b, const SyntheticWorld& world) {
  PinholeCamera cam_a, cam_b;
  double lo, hi;
  readMvsnetCam(dir + "/cams/" + viewName(a) + "_cam.txt", &cam_a, &lo, &hi);
  readMvsnetCam(dir + "/cams/" + viewName(b) + "_cam.txt", &cam_b, &lo, &hi);
  const ImageF depth_a = readPfm(dir + "/depth_gt/" + viewName(a) + ".pfm");
  const ImageF depth_b = readPfm(dir + "/depth_gt/" + viewName(b) + ".pfm");
  cam_a.width = cam_b.width = depth_a.width;
  cam_a.height = cam_b.height = depth_a.height;
  Agreement result;
  for (int y = 0; y < depth_a.height; ++y) {
    for (int x = 0; x < depth_a.width; ++x) {
      const double d = depth_a.at(x, y);
      if (!std::isfinite(d)) continue;
      const Eigen::Vector3d world_point = cam_a.R.transpose() * (cam_a.backproject(x, y, d) - cam_a.t);
      const Eigen::Vector3d in_b = cam_b.toCamera(world_point);
      if (in_b.z() <= 0) continue;
      const Eigen::Vector2d pixel = cam_b.project(in_b);
      if (!cam_b.contains(pixel)) continue;
      // Visibility from the scene itself: the first surface along B's ray.
      const double first = depthAt(world, cam_b, pixel.x(), pixel.y());
      if (first > in_b.z() * (1 + 1e-3)) ++result.behind;
      if (!(std::abs(first - in_b.z()) <= 1e-4 * in_b.z())) continue;  // occluded in B
      const double written = bilinearOffEdges(depth_b, pixel.x(), pixel.y());
      if (std::isnan(written)) continue;
      ++result.visible;
      if (std::abs(written - in_b.z()) <= 0.005 * in_b.z()) ++result.agreeing;
    }
  }
  return result;
}

TEST(SyntheticSequence, GroundTruthDepthAgreesAcrossFramesWhereVisible) {
  test::TempDir dir;
  const std::string out = synthetic(dir.file("seq"), "--scene room --views 6 --width 160 --height 120 --seed 3");
  const SyntheticWorld world = makeIndoorRoomWorld(3);
  for (const auto& pair : {std::make_pair(0, 1), std::make_pair(2, 5), std::make_pair(5, 0)}) {
    SCOPED_TRACE("frame " + std::to_string(pair.first) + " into frame " + std::to_string(pair.second));
    const Agreement r = projectInto(out, pair.first, pair.second, world);
    // A ray of B can pass a point of A only where it grazes a silhouette
    // (float32 depth): a handful of pixels at most.
    EXPECT_LE(r.behind, r.visible / 1000) << r.behind << " of " << r.visible;
    // The frames overlap: a good part of a frame is visible in the other.
    EXPECT_GT(r.visible, 160 * 120 / 4);
    EXPECT_GT(static_cast<double>(r.agreeing) / r.visible, 0.995) << r.agreeing << " of " << r.visible;
  }
}

TEST(SyntheticSequence, SameSeedSameFilesOtherSeedOtherScene) {
  test::TempDir dir;
  const std::string options = "--scene room --views 3 --width 64 --height 48 --seed ";
  const std::string a = synthetic(dir.file("a"), options + "5"), b = synthetic(dir.file("b"), options + "5");
  const std::string c = synthetic(dir.file("c"), options + "6");
  auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  };
  for (const std::string file : {"/images/00000002.png", "/depth_gt/00000002.pfm", "/cams/00000002_cam.txt"}) {
    SCOPED_TRACE(file);
    ASSERT_FALSE(bytes(a + file).empty());
    EXPECT_EQ(bytes(a + file), bytes(b + file));
    EXPECT_NE(bytes(a + file), bytes(c + file));
  }
}

// The shared option parser of the tools (tool_options.h): values are parsed
// whole, unknown options and missing values are named.
TEST(SyntheticSequence, BadOptionsAreClearErrors) {
  const std::string out = ::testing::TempDir() + "/synthetic_bad_options";
  const struct {
    const char* options;
    const char* message;
  } cases[] = {{"--views 3abc", "option --views: '3abc' is not a valid value"},
               {"--bogus 1", "unknown option --bogus"},
               {"--seed", "option --seed needs a value"},
               {"--views=1", "--views must be in 2..1000"}};
  for (const auto& c : cases) {
    const test::CommandResult r =
        test::runCommand(std::string(AMHMVS_TOOLS_DIR) + "/amhmvs_synthetic " + out + " " + c.options);
    EXPECT_EQ(r.exit_code, 1) << c.options << ": " << r.output;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.options << ": " << r.output;
  }
}

}  // namespace
}  // namespace amhmvs
