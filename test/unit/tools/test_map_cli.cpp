// The amhmvs_map command line: a synthetic room with exact ground truth, the
// real redkitchen (7-Scenes) recording with its Kinect depth reprojected into
// the colour camera, the MVSNet fountain, realtime replay with a small queue,
// and its messages for bad input. Floors were measured on the CPU backend at
// these settings (values in the comments) and set a little below.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

using test::CommandResult;
using test::runTool;

using test::jsonNumber;
using test::readText;

// Each (section, key) of the summary is above its floor.
struct Floor {
  const char* section;
  const char* key;
  double above;
};
void expectAbove(const std::string& summary, const std::vector<Floor>& floors) {
  for (const Floor& f : floors) {
    EXPECT_GT(jsonNumber(summary, f.section, f.key), f.above) << f.section << " " << f.key << ": " << summary;
  }
}

// Runs amhmvs_map from MVSNet folder `input` into `output` with `options`
// (expected to succeed; its log is printed when `echo`) and returns the
// written summary.json.
std::string mapRunSummary(const std::string& input, const std::string& output, const std::string& options,
                          bool echo = false) {
  const CommandResult run = runTool("amhmvs_map", input + " " + output + options);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  if (echo) std::cout << run.output;
  return readText(output + "/summary.json");
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

// How far keyframe_poses.txt of `out` is from the poses of the MVSNet
// folder's `cams` (cams/ the tracker's, cams_gt/ the true ones), keyframe k
// at stamp 0.5 k as amhmvs_synthetic writes them: the largest position
// difference in metres; -1 when a stamp or the count does not match.
double mostPositionDifference(const std::string& out, const std::string& folder, const std::string& cams, size_t count) {
  const std::vector<StampedPose> poses = readTumTrajectory(out + "/keyframe_poses.txt");
  if (poses.size() != count) return -1;
  double most = 0;
  for (size_t k = 0; k < poses.size(); ++k) {
    if (std::abs(poses[k].first - 0.5 * k) > 1e-9) return -1;
    PinholeCamera camera;
    double depth_min = 0, depth_max = 0;
    char name[32];
    std::snprintf(name, sizeof(name), "/%08zu_cam.txt", k);
    readMvsnetCam(folder + "/" + cams + name, &camera, &depth_min, &depth_max);
    most = std::max(most, (cameraToWorld(camera).translation() - poses[k].second.translation()).norm());
  }
  return most;
}

// The sequences below are PNG and JPEG: builds without OpenCV skip them
// (amhmvs_map there reads PPM/PGM, see PosedSequence's tests).
#define AMHMVS_REQUIRE_DECODER()                                                    \
  if (!canDecodeCompressedImages()) GTEST_SKIP() << "built without OpenCV (no PNG/JPEG decoder)"

// A synthetic room sequence (amhmvs_synthetic) shared by the tests below.
class MapCliRoom : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    // Rendered at 320x240 and mapped at 160x120: the ground-truth surface is
    // sampled twice as finely as the map.
    const CommandResult r = runTool("amhmvs_synthetic", dir_->file("room") +
                                                            " --scene room --views 6 --width 320 --height 240");
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
  AMHMVS_REQUIRE_DECODER();
  test::TempDir out;
  const CommandResult r = runTool("amhmvs_map", room() + " " + out.path() +
                                                     " --backend cpu --max_image_size 160 --iterations 3 "
                                                     "--num_sources 3 --write_previews");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::cout << r.output;
  const std::string summary = readText(out.file("summary.json"));
  EXPECT_EQ(jsonNumber(summary, "", "keyframes_picked"), 6) << summary;  // the room's views move > 5 cm
  EXPECT_NE(summary.find("\"interrupted_by\": null"), std::string::npos) << summary;  // a whole run
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
                                             jsonNumber(summary, "results", "source_only") +
                                             jsonNumber(summary, "results", "fused_again"));
  EXPECT_GT(jsonNumber(summary, "results", "fused_again"), 0) << summary;  // the first keyframes, with more views
  EXPECT_EQ(lineCount(out.file("keyframes.jsonl")), results);
  EXPECT_EQ(lineCount(out.file("keyframes.csv")), results + 1);
  // Both JSON files parse (strictly: no NaN), every row with its fields.
  const CommandResult parsed = test::runCommand(
      "python3 -c 'import json, sys; json.load(open(sys.argv[1])); "
      "rows = [json.loads(l) for l in open(sys.argv[2])]; "
      "print(len(rows), sum(len(r[\"sources\"]) for r in rows), sum(len(r[\"fused_ids\"]) for r in rows))' " +
      out.file("summary.json") + " " + out.file("keyframes.jsonl"));
  ASSERT_EQ(parsed.exit_code, 0) << parsed.output;
  EXPECT_EQ(parsed.output.substr(0, parsed.output.find(' ')), std::to_string(results)) << parsed.output;
  // Measured (CPU): depth within 1/2/5/10 %: 61.6 / 83.1 / 91.0 / 92.7 %,
  // completeness 99.1 %; published (confidence >= 0.97): 72.2 / 92.6 / 98.9 /
  // 99.4 %, completeness 60.1 %; map 14894 points, 85.1 % within 2 cm and
  // 99.4 % within 5 cm of the true surface (before session 9, without
  // fusing the first keyframes again: published 99.0 % within 5 % at 43.8 %,
  // map 13805 points, 85.5 / 99.3 %). Since the CPU estimate starts from the
  // neighbours' depth maps (neighbour_depth/start_from_neighbours auto):
  // depth 59.0 / 82.2 / 90.1 / 91.9 %, published 98.8 % within 5 % at 59.8 %,
  // map 25332 points, 83.5 / 99.3 % (without it, at that commit: 58.8 / 82.0 /
  // 90.3 / 92.1 %, 98.8 % at 59.6 %, 22892 points, 84.3 / 99.3 %): more
  // points, the added ones a little less precise.
  EXPECT_GT(jsonNumber(summary, "depth_accuracy", "within_1pct"), 58) << summary;
  EXPECT_GT(jsonNumber(summary, "depth_accuracy", "within_5pct"), 89) << summary;
  EXPECT_GT(jsonNumber(summary, "depth_accuracy", "within_10pct"), 90) << summary;
  EXPECT_GT(jsonNumber(summary, "depth_accuracy", "completeness_pct"), 97) << summary;
  EXPECT_GT(jsonNumber(summary, "published_depth_accuracy", "within_5pct"), 98) << summary;
  EXPECT_GT(jsonNumber(summary, "published_depth_accuracy", "completeness_pct"), 40) << summary;
  EXPECT_GT(jsonNumber(summary, "map", "within_2cm_pct"), 83) << summary;
  EXPECT_GT(jsonNumber(summary, "map", "within_5cm_pct"), 98) << summary;
  EXPECT_GT(jsonNumber(summary, "map", "points"), 22000) << summary;
}

// The same room as the realism mode's default profile renders it (a handheld
// camera behind a VIO tracker: pose noise and drift, timing offset, rolling
// shutter, blur, exposure changes, sensor noise): amhmvs_map takes the written
// poses as the tracker's and reports accuracy against the exact depth.
TEST(MapCli, RoomWithTheDefaultRealismProfile) {
  AMHMVS_REQUIRE_DECODER();
  test::TempDir dir;
  const CommandResult made = runTool("amhmvs_synthetic", dir.file("room") +
                                                            " --scene room --views 6 --width 320 --height 240 --realism default");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  // The paper's single scale, as when the floors below were measured: the
  // test is of the tracker settings, not of the estimator (the product's two
  // scales leave the bundle run's map at 85.1 % within 2 cm, not 5 points
  // above the again run's 88.8, and the thick run's at 89.5 %, below its 91).
  const std::string settings = " --backend cpu --max_image_size 160 --iterations 3 --num_sources 3 --multiscale 1";
  const CommandResult r =
      runTool("amhmvs_map", dir.file("room") + " " + dir.file("out") + settings + " --pose_refinement=0");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::cout << made.output << "\n" << r.output;
  const std::string summary = readText(dir.file("out/summary.json"));
  EXPECT_EQ(jsonNumber(summary, "results", "new") + jsonNumber(summary, "results", "late"), 6) << summary;
  // Measured (CPU): depth within 1/2/5/10 %: 8.4 / 18.2 / 38.0 / 61.5 %,
  // completeness 98.9 %; published (confidence >= 0.97): 44.8 % within 5 %,
  // completeness 26.5 %; map 87 points, 94.3 / 97.7 % within 2 / 5 cm of the
  // true surface (exact poses, MapCliRoom above: 91.0 % within 5 %). The pose
  // noise (2.6 px at 320 px) costs the most; issue 12 is to win it back.
  // Without fusing the first keyframes again when more views see them
  // (--confidence_again_with_more_views=0, before session 9): published
  // 51.0 % within 5 % at 19.8 %, map 71 points, 94.4 / 97.2 %. With
  // --fuse_neighbours_again (off by default): published 46.0 % within 5 %
  // at 32.1 %, map 95 points, 93.7 / 97.9 %.
  // The map is judged against the true surface (the depth at the true poses,
  // cams_gt/), not the truth moved by the tracker's error: the exact depth
  // maps placed at the tracker's poses, the best a map at those poses can do,
  // are 73.4 / 99.1 % within 2 / 5 cm of it.
  EXPECT_NE(summary.find("\"truth_at\": \"true poses\""), std::string::npos) << summary;
  EXPECT_NEAR(jsonNumber(summary, "exact_depth_at_tracker_poses", "within_2cm_pct"), 73.4, 0.5) << summary;
  EXPECT_NEAR(jsonNumber(summary, "exact_depth_at_tracker_poses", "within_5cm_pct"), 99.1, 0.5) << summary;
  expectAbove(summary, {{"depth_accuracy", "within_5pct", 35},
                        {"depth_accuracy", "within_10pct", 58},
                        {"depth_accuracy", "completeness_pct", 97},
                        {"published_depth_accuracy", "within_5pct", 42},
                        {"published_depth_accuracy", "completeness_pct", 24},
                        {"map", "points", 75},
                        {"map", "within_2cm_pct", 85},
                        {"map", "within_5cm_pct", 85}});

  // The same with the sources' poses refined before stereo (issue 12).
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage();
  // The fusion at 1 % relative depth, as when these floors were measured: the
  // online default of 2 % (more points for the confidence-masked keyframes)
  // gives 8451 points, 59.4 / 96.3 % within 2 / 5 cm of the true surface here.
  // The summary of a run with pose refinement and `extra` options into `name`/.
  // The estimate starts from random planes, as when these floors were
  // measured: the comparisons below isolate the pose refinement and the
  // rolling-shutter rectification. With the neighbours' depth as the start
  // (the CPU default) the refined map is 67.8 % within 2 cm and the rectified
  // one 66.8 %: the rectification's gain is gone there.
  const auto refinedRun = [&](const std::string& name, const std::string& extra) {
    return mapRunSummary(dir.file("room"), dir.file(name),
                         settings + " --pose_refinement=1 --fusion_max_relative_depth_difference 0.01"
                                    " --start_from_neighbours=false" + extra,
                         true);
  };
  const std::string refined_summary = refinedRun("refined", "");
  // Measured (CPU): 50.3 / 76.4 / 90.3 / 92.2 % within 1/2/5/10 %,
  // completeness 99.0 %; published: 98.8 % within 5 % at 61.2 %; map 4798
  // points, 58.1 % within 2 cm, 93.1 % within 5 cm of the true surface (the
  // clang sanitizer build: 5728 points, 59.7 / 90.5 %); the
  // exact depth at the tracker's poses: 73.4 / 99.1 %. Without fusing the
  // first keyframes again (--confidence_again_with_more_views=0): published
  // 99.0 % at 44.7 %, map 3772 points, 64.6 / 97.1 % (against the truth at
  // the tracker's poses, as measured before session 9: 91.0 / 99.2 %). Every
  // one of the 23 sources refined, median 43-90 ms per result.
  expectAbove(refined_summary, {{"depth_accuracy", "within_5pct", 87},
                                {"depth_accuracy", "within_10pct", 90},
                                {"depth_accuracy", "completeness_pct", 97},
                                {"published_depth_accuracy", "within_5pct", 97},
                                {"published_depth_accuracy", "completeness_pct", 58},
                                {"map", "points", 4300},
                                {"map", "within_2cm_pct", 55},
                                {"map", "within_5cm_pct", 89},
                                {"pose_refinement", "sources_refined", 20}});
  EXPECT_EQ(jsonNumber(refined_summary, "pose_refinement", "sources_rejected"), 0) << refined_summary;
  // The pipeline's counters (the nodelet's diagnostics) agree with the results.
  EXPECT_EQ(jsonNumber(refined_summary, "stats", "pose_sources_refined"),
            jsonNumber(refined_summary, "pose_refinement", "sources_refined"))
      << refined_summary;

  // And with the rolling shutter rectified (the profile's 25 ms readout;
  // frames 0.5 s apart, as amhmvs_synthetic writes them).
  const std::string rolling_shutter = " --frame_period 0.5 --rolling_shutter_s 0.025";
  const std::string rectified_summary = refinedRun("rectified", rolling_shutter);
  // Measured (CPU): 52.8 / 78.7 / 90.1 / 92.1 % within 1/2/5/10 %; map 6583
  // points, 63.9 / 95.2 % within 2 / 5 cm (without: 4798, 58.1 / 93.1 %); the
  // clang sanitizer build: 7025 points, 63.2 / 93.3 % (without: 5728, 59.7 / 90.5 %).
  // At 160 px the readout moves the image by half the pixels it does at 320,
  // where the map goes from 41.6 to 53.4 % within 2 cm (README).
  expectAbove(rectified_summary, {{"depth_accuracy", "within_5pct", 87},
                                  {"map", "points", 5900},
                                  {"map", "within_2cm_pct", 60},
                                  {"map", "within_5cm_pct", 91}});
  EXPECT_GT(jsonNumber(rectified_summary, "map", "within_2cm_pct"), jsonNumber(refined_summary, "map", "within_2cm_pct"));
  EXPECT_EQ(jsonNumber(rectified_summary, "stats", "rolling_shutter_rectified"), 6) << rectified_summary;
  EXPECT_EQ(jsonNumber(rectified_summary, "stats", "rolling_shutter_not_rectified"), 0) << rectified_summary;
  // Without a correction the map's keyframes are where the tracker put them.
  EXPECT_LT(mostPositionDifference(dir.file("rectified"), dir.file("room"), "cams", 6), 1e-6);
  EXPECT_GE(mostPositionDifference(dir.file("rectified"), dir.file("room"), "cams", 6), 0);

  // And the map at the keyframe pose graph's poses (the depth images are the same).
  const std::string graph_summary = refinedRun("graph", rolling_shutter + " --pose_refinement_correct_map_poses=1");
  // Measured (CPU): map 5533 points, 75.3 / 96.0 % within 2 / 5 cm (the clang
  // sanitizer build: 5960, 71.5 / 92.7 %); the exact depth maps at the map's
  // poses 100.0 / 100.0 % (at the tracker's 73.4 / 99.1 %). Fewer points:
  // the keyframes' points now share voxels.
  expectAbove(graph_summary, {{"map", "points", 4500},
                              {"map", "within_2cm_pct", 68},
                              {"map", "within_5cm_pct", 90},
                              {"exact_depth_at_map_poses", "within_2cm_pct", 97}});
  EXPECT_GT(jsonNumber(graph_summary, "map", "within_2cm_pct"), jsonNumber(rectified_summary, "map", "within_2cm_pct") + 5);
  EXPECT_NEAR(jsonNumber(graph_summary, "depth_accuracy", "within_5pct"),
              jsonNumber(rectified_summary, "depth_accuracy", "within_5pct"), 1e-9);

  // And each keyframe fused again once a refinement replaced a depth map it
  // was checked against (--fuse_neighbours_again, off by default; README
  // "Settings that matter behind a real tracker"). Measured (CPU): map
  // 4028 points, 78.7 / 97.2 % within 2 / 5 cm, 9 fusions again (the graph
  // run above: 3).
  const std::string again_summary =
      refinedRun("again", rolling_shutter + " --pose_refinement_correct_map_poses=1 --fuse_neighbours_again");
  expectAbove(again_summary, {{"map", "points", 3500},
                              {"map", "within_2cm_pct", 70},
                              {"map", "within_5cm_pct", 90}});
  EXPECT_GT(jsonNumber(again_summary, "results", "fused_again"), jsonNumber(graph_summary, "results", "fused_again"))
      << again_summary;

  // And one bundle adjustment over all keyframes instead of the graph, its
  // poses the stereo's, the fusion's and the map's, keyframes estimated again
  // when it moves their sources (session 22). Measured (CPU): 65.2 / 82.9 /
  // 90.6 / 92.3 % within 1/2/5/10 % (the run above: 52.8 / 78.7 / 90.1 /
  // 92.1), 18 refinements (4), map 10093 points, 90.5 / 99.6 % within 2 / 5 cm
  // (4028, 78.7 / 97.2 %).
  const std::string bundle_summary =
      refinedRun("bundle", rolling_shutter +
                               " --pose_refinement_correct_map_poses=1 --fuse_neighbours_again"
                               " --pose_refinement_keyframe_bundle_adjustment=1");
  expectAbove(bundle_summary, {{"depth_accuracy", "within_1pct", 60},
                               {"map", "points", 8500},
                               {"map", "within_2cm_pct", 85},
                               {"map", "within_5cm_pct", 98}});
  EXPECT_GT(jsonNumber(bundle_summary, "depth_accuracy", "within_1pct"),
            jsonNumber(again_summary, "depth_accuracy", "within_1pct") + 5)
      << bundle_summary;
  EXPECT_GT(jsonNumber(bundle_summary, "map", "within_2cm_pct"), jsonNumber(again_summary, "map", "within_2cm_pct") + 5)
      << bundle_summary;
  EXPECT_GT(jsonNumber(bundle_summary, "results", "refined"), jsonNumber(again_summary, "results", "refined"))
      << bundle_summary;
  // keyframe_poses.txt has the adjusted poses, not the tracker's. Measured
  // (CPU): up to 18.7 mm from the tracker's (whose error is about 16 mm).
  EXPECT_GT(mostPositionDifference(dir.file("bundle"), dir.file("room"), "cams", 6), 0.01);

  // The same map without its thin voxels (--min_points_per_voxel 2): the
  // same fused points, fewer of them exported, and those closer to the
  // surface. Measured (CPU): 3713 points, 93.0 % within 2 cm (the bundle run
  // above: 10093, 90.5 %); each keyframe's pixels in the exported map: least
  // 4.3 %, median 8.6 % (8.4 %, 14.4 %). At 160 px a 2 cm voxel gets a
  // quarter of the points it gets at 320 px: the threshold goes with the
  // resolution (README "The map's thin voxels").
  const std::string thick_summary =
      refinedRun("thick", rolling_shutter +
                              " --pose_refinement_correct_map_poses=1 --fuse_neighbours_again"
                              " --pose_refinement_keyframe_bundle_adjustment=1 --min_points_per_voxel 2");
  EXPECT_NEAR(jsonNumber(thick_summary, "depth_accuracy", "within_1pct"),
              jsonNumber(bundle_summary, "depth_accuracy", "within_1pct"), 1e-9);
  EXPECT_LT(jsonNumber(thick_summary, "map", "points"), jsonNumber(bundle_summary, "map", "points"));
  EXPECT_GT(jsonNumber(thick_summary, "map", "within_2cm_pct"), jsonNumber(bundle_summary, "map", "within_2cm_pct"));
  expectAbove(thick_summary, {{"map", "points", 3000}, {"map", "within_2cm_pct", 91}});
  EXPECT_LT(jsonNumber(thick_summary, "map", "keyframe_pixels_in_map_pct_median"),
            jsonNumber(bundle_summary, "map", "keyframe_pixels_in_map_pct_median"));

  // A keyframe is estimated again on a smaller change of a source's baseline
  // length with --pose_refinement_reestimate_length_change (0.002 above).
  const std::string sensitive_summary =
      refinedRun("sensitive", rolling_shutter +
                                  " --pose_refinement_correct_map_poses=1 --fuse_neighbours_again"
                                  " --pose_refinement_keyframe_bundle_adjustment=1"
                                  " --pose_refinement_reestimate_length_change 0.00001");
  EXPECT_GT(jsonNumber(sensitive_summary, "results", "refined"), jsonNumber(bundle_summary, "results", "refined"))
      << sensitive_summary;
}

// At the true poses the keyframe bundle adjustment confirms every keyframe
// and moves none: the map and its alignments to the true poses agree.
TEST(MapCli, KeyframeBundleAdjustmentKeepsTheTruePoses) {
  AMHMVS_REQUIRE_DECODER();
  if (!PoseRefiner::available()) GTEST_SKIP() << PoseRefiner::unavailableMessage();
  test::TempDir dir;
  const CommandResult made = runTool("amhmvs_synthetic", dir.file("room") +
                                                            " --scene room --views 6 --width 320 --height 240 --realism default");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  fs::remove_all(dir.file("room/cams"));
  fs::copy(dir.file("room/cams_gt"), dir.file("room/cams"));
  const std::string bundle = mapRunSummary(
      dir.file("room"), dir.file("bundle"),
      " --backend cpu --max_image_size 160 --iterations 3 --num_sources 3 --pose_refinement=1"
      " --fusion_max_relative_depth_difference 0.01 --frame_period 0.5 --rolling_shutter_s 0.025"
      " --pose_refinement_correct_map_poses=1 --fuse_neighbours_again --pose_refinement_keyframe_bundle_adjustment=1");
  // Measured (CPU): map 8246 points, 83.2 % within 2 cm, 99.0 % within 5 cm.
  expectAbove(bundle, {{"map", "within_2cm_pct", 80}});
  EXPECT_EQ(jsonNumber(bundle, "stats", "rolling_shutter_rectified"), 6) << bundle;
  // The poses are the true ones: the similarity to them is the identity.
  EXPECT_NEAR(jsonNumber(bundle, "after_similarity_to_true_poses", "scale"), 1.0, 1e-6) << bundle;
  EXPECT_NEAR(jsonNumber(bundle, "after_similarity_to_true_poses", "within_2cm_pct"),
              jsonNumber(bundle, "map", "within_2cm_pct"), 1e-6)
      << bundle;
  // ... and what is left of each keyframe's pose error after it is nothing.
  EXPECT_LT(jsonNumber(bundle, "after_similarity_to_true_poses", "keyframe_position_error_mm_max"), 1e-6) << bundle;
  EXPECT_LT(jsonNumber(bundle, "after_similarity_to_true_poses", "keyframe_rotation_error_deg_max"), 1e-6) << bundle;
  // So is the rigid alignment (the one to read behind an RGB-D tracker).
  EXPECT_EQ(jsonNumber(bundle, "after_rigid_alignment_to_true_poses", "scale"), 1.0) << bundle;
  EXPECT_NEAR(jsonNumber(bundle, "after_rigid_alignment_to_true_poses", "within_2cm_pct"),
              jsonNumber(bundle, "map", "within_2cm_pct"), 1e-6)
      << bundle;
  EXPECT_LT(jsonNumber(bundle, "after_rigid_alignment_to_true_poses", "keyframe_position_error_mm_max"), 1e-6)
      << bundle;
}

// Runs amhmvs_map with `arguments`, sends it `signal` as soon as its output
// holds `trigger` (a result line says what the program has done, so the
// signal follows its progress, not a clock), and returns its exit code and
// output.
CommandResult interruptWhenPrinted(const std::string& arguments, const std::string& trigger, int signal) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) return {-1, "pipe failed"};
  const std::string command = "exec " + std::string(AMHMVS_TOOLS_DIR) + "/amhmvs_map " + arguments + " 2>&1";
  const pid_t child = ::fork();
  if (child == 0) {
    ::dup2(pipe_fds[1], STDOUT_FILENO);
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  CommandResult result{-1, ""};
  bool signalled = false;
  char buffer[4096];
  for (ssize_t n; (n = ::read(pipe_fds[0], buffer, sizeof(buffer))) > 0;) {
    result.output.append(buffer, n);
    if (!signalled && result.output.find(trigger) != std::string::npos) {
      ::kill(child, signal);
      signalled = true;
    }
  }
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (!signalled) result.output += "\n(test: '" + trigger + "' never came, no signal sent)";
  return result;
}

// Ctrl-C (or SIGTERM) mid-run: no more frames are read, the keyframes in the
// pipeline are finished, and the map, the poses and the summary are written
// whole and agree with each other; exit 130 / 143.
TEST_F(MapCliRoom, InterruptedRunWritesTheMapAndSummaryOfWhatItDid) {
  AMHMVS_REQUIRE_DECODER();
  const std::string options = " --backend cpu --max_image_size 160 --iterations 3 --num_sources 2 --write_clouds=0 "
                              "--write_depth=0";
  struct Case {
    int signal;
    const char* name;
    int exit_code;
    const char* mode;
    const char* trigger;
  };
  // Realtime at 0.5x: frames come 1 s apart; the stop comes when the first
  // keyframe is in the map, while the feeder waits for the next frame.
  // Offline: at the first result, while the next keyframes are estimated.
  for (const Case& c : {Case{SIGINT, "SIGINT", 130, " --realtime 0.5", ", fused "},
                        Case{SIGTERM, "SIGTERM", 143, "", "] keyframe "}}) {
    test::TempDir out;
    const CommandResult r = interruptWhenPrinted(room() + " " + out.path() + options + c.mode, c.trigger, c.signal);
    ASSERT_EQ(r.exit_code, c.exit_code) << c.name << "\n" << r.output;
    EXPECT_NE(r.output.find("interrupted by " + std::string(c.name)), std::string::npos) << r.output;
    const std::string summary = readText(out.file("summary.json"));
    EXPECT_NE(summary.find("\"interrupted_by\": \"" + std::string(c.name) + "\""), std::string::npos) << summary;
    EXPECT_EQ(jsonNumber(summary, "", "keyframes_picked"), 6) << summary;
    EXPECT_LT(jsonNumber(summary, "", "keyframes_pushed"), 6) << c.name << ": stopped before the end\n" << summary;
    const PointCloud map = readPly(out.file("map.ply"));
    EXPECT_EQ(static_cast<double>(map.size()), jsonNumber(summary, "map", "points")) << summary;
    EXPECT_LE(static_cast<double>(readTumTrajectory(out.file("keyframe_poses.txt")).size()),
              jsonNumber(summary, "", "keyframes_pushed"))
        << summary;
    if (c.signal == SIGINT) EXPECT_GT(map.size(), 0u) << "a keyframe was fused before the stop\n" << summary;
  }
}

// The written depth is NaN exactly where the written confidence is below
// --confidence_level; --confidence=0 writes every depth map unmasked when it
// is estimated and reports no published accuracy.
TEST_F(MapCliRoom, WrittenDepthIsMaskedWhereTheConfidenceIsBelowTheLevel) {
  AMHMVS_REQUIRE_DECODER();
  const std::string options = " --backend cpu --max_image_size 80 --iterations 2 --num_sources 2 --write_clouds=0";
  test::TempDir out;
  const CommandResult r =
      runTool("amhmvs_map", room() + " " + out.path() + options + " --write_confidence --confidence_level 0.9");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  size_t masked = 0, kept = 0;
  for (long id = 0; id < 6; ++id) {
    if (!fs::exists(out.file("confidence/" + id6(id) + ".pfm"))) continue;  // never fused
    const ImageF depth = readPfm(out.file("depth/" + id6(id) + ".pfm"));
    const ImageF confidence = readPfm(out.file("confidence/" + id6(id) + ".pfm"));
    ASSERT_TRUE(confidence.sameSize(depth.width, depth.height));
    for (size_t i = 0; i < depth.data.size(); ++i) {
      ASSERT_TRUE(confidence.data[i] >= 0 && confidence.data[i] <= 1) << id << " " << i;
      if (confidence.data[i] < 0.9f) EXPECT_TRUE(std::isnan(depth.data[i])) << id << " " << i;
      masked += confidence.data[i] < 0.9f;
      kept += confidence.data[i] >= 0.9f && std::isfinite(depth.data[i]);
    }
  }
  EXPECT_GT(masked, 0u);
  EXPECT_GT(kept, 0u);
  const std::string summary = readText(out.file("summary.json"));
  EXPECT_EQ(jsonNumber(summary, "published_depth_accuracy", "confidence_level"), 0.9) << summary;

  test::TempDir unmasked;
  const CommandResult off = runTool("amhmvs_map", room() + " " + unmasked.path() + options + " --confidence=0");
  ASSERT_EQ(off.exit_code, 0) << off.output;
  EXPECT_NE(readText(unmasked.file("summary.json")).find("\"published_depth_accuracy\": null"), std::string::npos);
  EXPECT_FALSE(fs::exists(unmasked.file("confidence")));
  for (long id = 0; id < 6; ++id) EXPECT_TRUE(fs::exists(unmasked.file("depth/" + id6(id) + ".pfm"))) << id;
}

// Realtime replay at 100x the recording's rate (a frame every 10 ms) with a
// queue of one: the estimator cannot keep up, the oldest waiting keyframe is
// dropped, every keyframe that was not dropped gets exactly one first result.
TEST_F(MapCliRoom, RealtimeReplayDropsWhatTheQueueCannotHold) {
  AMHMVS_REQUIRE_DECODER();
  test::TempDir out;
  const CommandResult r = runTool("amhmvs_map", room() + " " + out.path() +
                                                     " --backend cpu --max_image_size 96 --iterations 2 "
                                                     "--num_sources 2 --realtime 100 --queue_size 1 "
                                                     "--write_depth=0 --write_clouds=0");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string summary = readText(out.file("summary.json"));
  EXPECT_EQ(jsonNumber(summary, "", "keyframes_pushed"), 6) << summary;
  EXPECT_EQ(jsonNumber(summary, "stats", "keyframes_received"), 6) << summary;
  const double dropped = jsonNumber(summary, "stats", "dropped: queue_full");
  EXPECT_GE(dropped, 1) << summary;
  EXPECT_EQ(jsonNumber(summary, "results", "new") + jsonNumber(summary, "results", "source_only"), 6 - dropped)
      << summary;
  EXPECT_FALSE(fs::exists(out.file("depth")));
  EXPECT_FALSE(fs::exists(out.file("clouds")));
  EXPECT_TRUE(fs::exists(out.file("map.ply")));
}

// An image that cannot be decoded halfway through (its header still gives the
// size, so the sequence reads): exit 1 naming it, after the earlier results
// were written and the writer thread ended cleanly.
TEST_F(MapCliRoom, AnUnreadableImageMidwayStopsWithItsName) {
  AMHMVS_REQUIRE_DECODER();
  test::TempDir copy;
  const std::string room_copy = copy.file("room");
  fs::copy(room(), room_copy, fs::copy_options::recursive);
  const std::string bad = room_copy + "/images/00000003.png";
  fs::resize_file(bad, 100);  // PNG signature and IHDR kept, image data cut
  const CommandResult r = runTool("amhmvs_map", room_copy + " " + copy.file("out") +
                                                     " --backend cpu --max_image_size 64 --iterations 1 --num_sources 1");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("00000003.png"), std::string::npos) << r.output;
  EXPECT_GE(lineCount(copy.file("out/keyframes.csv")), 3u) << r.output;  // header and the first results
}

TEST(MapCli, HelpAndBadInput) {
  const CommandResult help = runTool("amhmvs_map", "--help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--backend", "--max_image_size", "--num_sources", "--iterations", "--start", "--count",
                             "--stride", "--keyframe_min_translation", "--keyframe_min_rotation_deg", "--queue_size",
                             "--voxel_size", "--realtime", "--write_depth", "--write_previews", "--write_clouds",
                             "--intrinsics", "--color_offset", "7-Scenes", "TUM RGB-D", "COLMAP", "MVSNet",
                             "--confidence", "--confidence_level", "--write_confidence", "--fusion_max_reprojection_error",
                             "--fusion_max_relative_depth_difference", "--fusion_min_consistent_views"}) {
    EXPECT_NE(help.output.find(option), std::string::npos) << option;
  }
  EXPECT_EQ(runTool("amhmvs_map", "").exit_code, 2);
  EXPECT_EQ(runTool("amhmvs_map", "only_one_argument").exit_code, 2);
  test::TempDir dir;
  auto expectFailure = [&](const std::string& arguments, const std::string& needle1, const std::string& needle2) {
    const CommandResult r = runTool("amhmvs_map", arguments);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(needle1), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(needle2), std::string::npos) << r.output;
  };
  expectFailure(dir.file("missing") + " " + dir.file("out"), "missing", "does not exist");
  dir.write("other/notes.txt", "x");
  expectFailure(dir.file("other") + " " + dir.file("out"), "other", "not a posed sequence");
  expectFailure(dir.file("other") + " " + dir.file("out") + " --bogus 1", "unknown option", "--bogus");
  expectFailure(dir.file("other") + " " + dir.file("out") + " --intrinsics kinect", "kinect", "freiburg1");
  expectFailure(dir.file("other") + " " + dir.file("out") + " --confidence_level 2", "confidence",
                "min_probability must be in [0, 1]");
  dir.write("tum/rgb.txt", "1.0 rgb/1.png\n");
  dir.write("tum/groundtruth.txt", "1.0 0 0 0 0 0 0\n");
  expectFailure(dir.file("tum") + " " + dir.file("out"), "groundtruth.txt: line 1", "8 fields");
}

// The real redkitchen recording (7-Scenes layout, Kinect v1 at 15 Hz here):
// 40 frames at 160x120, 3 iterations, with the fitted colour registration of
// ../shared/data/README.md. Its ground truth is raw Kinect depth reprojected
// into the colour camera: good to a few per cent, so floors at 5 and 10 %.
TEST(MapCli, RedkitchenSevenScenesAgainstKinectDepth) {
  AMHMVS_REQUIRE_DECODER();
  AMHMVS_REQUIRE_DATA(sequence, "redkitchen_7scenes");
  test::TempDir out;
  const CommandResult r = runTool(
      "amhmvs_map", sequence + " " + out.path() +
                        " --backend cpu --max_image_size 160 --count 40 --iterations 3 --intrinsics fitted7scenes"
                        " --color_offset=-0.010,0,0 --depth_min 0.5 --depth_max 4.5 --scene_depth 2 --num_sources 4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::cout << r.output;
  const std::string summary = readText(out.file("summary.json"));
  // Measured (CPU): 8 keyframes of 40 frames (6 new, 2 late, 4 refined);
  // depth within 5/10 %: 47.0 / 64.8 %, completeness 98.0 %; published
  // (confidence >= 0.97): 71.5 / 87.1 %, completeness 42.5 %; map 1146
  // points, 34.3 % within 2 cm and 92.1 % within 5 cm of the Kinect surface.
  // Without fusing the first keyframes again when more views see them
  // (--confidence_again_with_more_views=0, before session 9): published
  // 73.1 / 88.0 % at 26.7 %, map 919 points, 30.8 / 92.3 %.
  // With --fuse_neighbours_again (off by default; better at 320 px and 60
  // frames: README) this small run gives published 72.8 / 87.3 % at 39.7 %,
  // map 1124 points, 30.6 / 90.5 %.
  EXPECT_EQ(jsonNumber(summary, "", "keyframes_picked"), 8) << summary;
  EXPECT_EQ(jsonNumber(summary, "results", "new") + jsonNumber(summary, "results", "late"), 8) << summary;
  expectAbove(summary, {{"depth_accuracy", "within_5pct", 45},
                        {"depth_accuracy", "within_10pct", 62},
                        {"depth_accuracy", "completeness_pct", 95},
                        {"published_depth_accuracy", "within_5pct", 69},
                        {"published_depth_accuracy", "within_10pct", 85},
                        {"published_depth_accuracy", "completeness_pct", 40},
                        {"map", "within_5cm_pct", 90},
                        {"map", "points", 1000}});
  const ImageF depth = readPfm(out.file("depth/000042.pfm"));
  EXPECT_EQ(depth.width, 160);
  EXPECT_EQ(depth.height, 120);
}

// The same frames at KinectFusion's poses with the sources aligned to each
// keyframe photometrically (mapping/direct_alignment.h; the estimator's
// defaults otherwise), against the same run without.
TEST(MapCli, RedkitchenWithDirectAlignment) {
  AMHMVS_REQUIRE_DECODER();
  AMHMVS_REQUIRE_DATA(sequence, "redkitchen_7scenes");
  test::TempDir out;
  const CommandResult r = runTool("amhmvs_map", sequence + " " + out.path() +
                                                    " --backend cpu --max_image_size 160 --count 40 --intrinsics "
                                                    "fitted7scenes --color_offset=-0.010,0,0 --direct_alignment");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::cout << r.output;
  const std::string summary = readText(out.file("summary.json"));
  // Measured (CPU): depth within 2/5/10 % 24.4 / 51.9 / 73.4 % (without the
  // alignment 18.8 / 46.6 / 64.9 %); published 65.0 % within 5 % at 46.5 %
  // (68.6 % at 43.8 %); map 4347 points, 69.6 / 94.9 % within 2 / 5 cm (3995
  // points, 29.5 / 87.5 %); 39 of 40 sources aligned (the first keyframe's
  // source has no depth map yet).
  expectAbove(summary, {{"depth_accuracy", "within_2pct", 22},
                        {"depth_accuracy", "within_5pct", 50},
                        {"depth_accuracy", "within_10pct", 70},
                        {"map", "within_2cm_pct", 60},
                        {"map", "within_5cm_pct", 92},
                        {"direct_alignment", "sources_aligned", 30}});
  EXPECT_EQ(jsonNumber(summary, "direct_alignment", "sources_rejected"), 0) << summary;
  // The weakly textured pixels (core/texture.h) reported apart: measured
  // 22.4 % of the truth's pixels, 41.8 % of them within 5 % (all: 51.9 %).
  EXPECT_NEAR(jsonNumber(summary, "weak_texture", "share_of_truth_pixels_pct"), 22.4, 3) << summary;
  EXPECT_LT(jsonNumber(summary, "weak_texture", "within_5pct"), jsonNumber(summary, "depth_accuracy", "within_5pct") - 5)
      << summary;
  // The pipeline's counter (the nodelet's diagnostics) agrees with the results.
  EXPECT_EQ(jsonNumber(summary, "stats", "sources_aligned"), jsonNumber(summary, "direct_alignment", "sources_aligned"))
      << summary;
}

// The MVSNet fountain (no dense ground truth): the first 5 views at 192x128,
// depth ranges from the cam files.
TEST(MapCli, FountainDenseFolderUsesItsDepthRanges) {
  AMHMVS_REQUIRE_DECODER();
  AMHMVS_REQUIRE_DATA(sequence, "mvsnet/fountain_x0.25");
  test::TempDir out;
  const CommandResult r = runTool("amhmvs_map", sequence + " " + out.path() +
                                                    " --backend cpu --max_image_size 192 --count 5 --iterations 3"
                                                    " --num_sources 3 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string summary = readText(out.file("summary.json"));
  // Measured (CPU): 5 keyframes (4 new, 1 late, 4 refined), map 8840 points.
  EXPECT_EQ(jsonNumber(summary, "", "keyframes_picked"), 5) << summary;
  EXPECT_EQ(jsonNumber(summary, "results", "new") + jsonNumber(summary, "results", "late"), 5) << summary;
  EXPECT_GT(jsonNumber(summary, "map", "points"), 8000) << summary;
  EXPECT_NE(summary.find("\"depth_accuracy\": null"), std::string::npos) << summary;
  const std::string rows = readText(out.file("keyframes.jsonl"));
  EXPECT_NE(rows.find("\"depth_range_source\": \"given\""), std::string::npos) << rows;
  EXPECT_EQ(rows.find("neighbour"), std::string::npos) << rows;
  const ImageF depth = readPfm(out.file("depth/000004.pfm"));
  EXPECT_EQ(depth.width, 192);
  EXPECT_EQ(depth.height, 128);
}

}  // namespace
}  // namespace amhmvs
