// The amhmvs_depth command line on the real data: outputs, options, and a
// clear message and exit code for each class of bad input.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"
#include "depth_job.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

using test::CommandResult;

CommandResult runDepth(const std::string& arguments) {
  return test::runCommand(std::string(AMHMVS_DEPTH_BIN) + " " + arguments);
}

// A writable copy of the Piano two-view dense folder.
class DepthCli : public ::testing::Test {
 protected:
  void SetUp() override {
    source_ = test::dataPath("mvsnet/middlebury2014_Piano");
    if (source_.empty()) GTEST_SKIP() << "real data not found under " << test::dataDir();
    fs::copy(source_, dir_.file("in"), fs::copy_options::recursive);
    input_ = dir_.file("in");
    output_ = dir_.file("out");
  }
  // Runs on the copy with a quick configuration and expects failure.
  void expectFailure(const std::string& extra, const std::string& needle1,
                     const std::string& needle2) {
    const CommandResult r = runDepth(input_ + " " + output_ + " --backend cpu --max_image_size 120 "
                                     "--iterations 1 " + extra);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(needle1), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(needle2), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("Segmentation"), std::string::npos);
  }
  void replaceCamLine(int view, int line_number, const std::string& text) {
    const std::string path = input_ + "/cams/0000000" + std::to_string(view) + "_cam.txt";
    std::ifstream in(path);
    std::ostringstream out;
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) out << (n == line_number ? text : line) << "\n";
    in.close();
    std::ofstream(path) << out.str();
  }

  test::TempDir dir_;
  std::string source_, input_, output_;
};

// amhmvs_depth asks for one CUDA work queue before its first CUDA call
// (faster context start and end), but a number the user set wins.
TEST(DepthJobEnvironment, OneCudaWorkQueueUnlessTheUserChoseANumber) {
  const char* name = "CUDA_DEVICE_MAX_CONNECTIONS";
  const char* before = std::getenv(name);
  const std::string saved = before ? before : "";
  unsetenv(name);
  preferOneCudaWorkQueue();
  ASSERT_NE(std::getenv(name), nullptr);
  EXPECT_STREQ(std::getenv(name), "1");
  setenv(name, "8", 1);
  preferOneCudaWorkQueue();
  EXPECT_STREQ(std::getenv(name), "8");
  if (before) {
    setenv(name, saved.c_str(), 1);
  } else {
    unsetenv(name);
  }
}

TEST_F(DepthCli, WritesEveryOutputAtTheProcessedResolution) {
  const CommandResult r = runDepth(input_ + " " + output_ +
                                   " --backend cpu --max_image_size 240 --iterations 3 --views 0");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("[1/1] view 00000000"), std::string::npos) << r.output;
  const std::string view = output_ + "/00000000";
  const ImageF depth = readPfm(view + "/depth.pfm");
  const ImageF normal = readPfm(view + "/normal.pfm");
  const ImageF cost = readPfm(view + "/cost.pfm");
  EXPECT_EQ(depth.width, 240);
  EXPECT_EQ(depth.height, 163);  // 707x481 scaled to a longest side of 240
  EXPECT_EQ(normal.channels, 3);
  EXPECT_TRUE(cost.sameSize(depth.width, depth.height));
  long finite = 0;
  for (float d : depth.data) finite += std::isfinite(d) && d > 1.0 && d < 4.0;
  EXPECT_GT(finite, 0.9 * depth.data.size());
  int w = 0, h = 0;
  ASSERT_TRUE(readImageSize(view + "/depth.png", &w, &h));
  EXPECT_EQ(w, 240);
  PinholeCamera camera;
  double dmin, dmax;
  readMvsnetCam(view + "/cam.txt", &camera, &dmin, &dmax);
  EXPECT_NEAR(camera.fx, 713.189 * 240.0 / 707.0, 1e-3);  // K scaled with the image
  EXPECT_NEAR(dmin, 1.176846, 1e-6);
}

TEST_F(DepthCli, CostMaskSetsUnreliablePixelsToNaN) {
  const CommandResult r = runDepth(input_ + " " + output_ +
                                   " --backend cpu --max_image_size 120 --iterations 2 --max_cost 0.3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ImageF depth = readPfm(output_ + "/00000000/depth.pfm");
  const ImageF cost = readPfm(output_ + "/00000000/cost.pfm");
  for (size_t i = 0; i < depth.data.size(); ++i) {
    if (cost.data[i] > 0.3f) EXPECT_TRUE(std::isnan(depth.data[i]));
  }
}

// Files are written by a background thread: a file that cannot be written
// still fails the program with its name.
TEST_F(DepthCli, MiddleburySceneFolderIsTheGroundTruthOfView0) {
  const std::string scene = test::dataPath("middlebury2014/Piano");
  if (scene.empty()) GTEST_SKIP() << "real data not found under " << test::dataDir();
  const CommandResult r = runDepth(input_ + " " + output_ + " --backend cpu --max_image_size 120 --iterations 2 " +
                                   "--ground_truth " + scene);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // View 0 is judged (non-occluded pixels at 120x82); view 1 has no ground
  // truth; the pooled line is view 0's.
  std::smatch view0, pooled;
  ASSERT_TRUE(std::regex_search(r.output, view0, std::regex("view 00000000: .* ground truth: ([0-9./ ]+) %")))
      << r.output;
  EXPECT_TRUE(std::regex_search(r.output, std::regex("view 00000001: [^\n]* ms\n"))) << r.output;
  ASSERT_TRUE(std::regex_search(r.output, pooled, std::regex("over 2 maps \\(([0-9]+) pixels\\): within 1/2/5 %: ([0-9./ ]+) %")))
      << r.output;
  EXPECT_EQ(pooled[2].str(), view0[1].str());
  EXPECT_GT(std::stol(pooled[1].str()), 0.8 * 120 * 82);
}

TEST_F(DepthCli, UnwritableOutputFileIsReportedWithItsName) {
  fs::create_directories(output_ + "/00000000/normal.pfm");  // a folder where the file goes
  const CommandResult r = runDepth(input_ + " " + output_ + " --backend cpu --max_image_size 120 --iterations 1");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(output_ + "/00000000/normal.pfm"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("Segmentation"), std::string::npos);
}

TEST_F(DepthCli, HelpDocumentsEveryMethodOption) {
  const CommandResult r = runDepth("--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const OptionInfo& info : patchMatchOptionTable()) {
    EXPECT_NE(r.output.find("--" + info.name), std::string::npos) << info.name;
  }
  for (const char* option : {"--views", "--num_sources", "--max_image_size", "--backend", "--max_cost"}) {
    EXPECT_NE(r.output.find(option), std::string::npos) << option;
  }
}

TEST_F(DepthCli, MissingInputFolder) {
  input_ = dir_.file("none");
  expectFailure("", "none", "does not exist");
}

TEST_F(DepthCli, NotADenseFolder) {
  fs::remove_all(input_ + "/cams");
  expectFailure("", "neither an MVSNet dense folder", "COLMAP");
}

TEST_F(DepthCli, MalformedCamFile) {
  replaceCamLine(1, 8, "713.189 0.0 abc");
  expectFailure("", "00000001_cam.txt", "line 8");
}

TEST_F(DepthCli, NonPositiveFocalLength) {
  replaceCamLine(0, 8, "-713.189 0.0 356.021");
  expectFailure("", "00000000_cam.txt", "focal");
}

TEST_F(DepthCli, NonFiniteAndNonRigidPoses) {
  replaceCamLine(1, 2, "nan 0.0 0.0 -0.178089");
  expectFailure("", "00000001_cam.txt", "finite");
  replaceCamLine(1, 2, "2.0 0.0 0.0 -0.178089");
  expectFailure("", "00000001_cam.txt", "rigid");
}

TEST_F(DepthCli, InvertedDepthRange) {
  replaceCamLine(0, 12, "3.778219 0.013620 192.000000 1.176846");
  expectFailure("", "00000000_cam.txt", "depth");
}

TEST_F(DepthCli, ImageThatDoesNotMatchItsCamera) {
  writePnm(input_ + "/images/00000001.pgm", ImageU8(100, 80, 1, 128));
  fs::remove(input_ + "/images/00000001.png");
  expectFailure("", "00000001", "does not match its camera");
}

TEST_F(DepthCli, MoreSourcesThanSupported) { expectFailure("--num_sources 33", "max_sources", "32"); }

TEST_F(DepthCli, UnknownOptionAndBadValues) {
  expectFailure("--no_such_option 1", "unknown option", "--no_such_option");
  expectFailure("--beta zero", "beta", "not a valid number");
  expectFailure("--backend gpu", "backend", "auto, cuda, cpu");
  expectFailure("--depth_min 3 --depth_max 2", "depth range", "invalid");
}

// Option values that parse but mean nothing are refused, not ignored.
TEST_F(DepthCli, OptionValuesOutsideTheirMeaningAreRefused) {
  expectFailure("--depth_min -1 --depth_max -0.5", "--depth_min -1", "need 1e-12 <= depth_min");
  expectFailure("--depth_min 1e-300 --depth_max 1e300", "depth range", "depth_max <= 1e+12");
  expectFailure("--depth_min 2", "--depth_min and --depth_max", "together");
  expectFailure("--max_cost -1", "--max_cost -1", "must be > 0");
  expectFailure("--views 0,0", "--views", "view 0 is listed twice");
  expectFailure("--max_image_size 1", "--max_image_size 1", "must be 0 (no limit) or >= 16");
}

TEST_F(DepthCli, EmptyOutputDirIsRefused) {
  const CommandResult r = runDepth(input_ + " '' --backend cpu --max_image_size 120 --iterations 1");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("OUTPUT_DIR is empty"), std::string::npos) << r.output;
}

// Degenerate but finite cameras are refused at load, naming the cam file.
TEST_F(DepthCli, DegenerateCamerasAreRefusedAtLoad) {
  replaceCamLine(1, 2, "1.0 0.0 0.0 1e308");
  expectFailure("", "00000001_cam.txt", "camera centre is 1e+308 from the world origin");
  replaceCamLine(1, 2, "1.0 0.0 0.0 -0.178089");
  replaceCamLine(1, 8, "1e-300 0.0 356.021");
  expectFailure("", "00000001_cam.txt", "focal length (fx=1e-300");
  replaceCamLine(1, 8, "1e300 0.0 356.021");
  expectFailure("", "00000001_cam.txt", "focal length (fx=1e+300");
}

// A camera that is valid at full size but not at the processed size is named
// by its view id (the estimator only knows "source view <index>").
TEST_F(DepthCli, CameraInvalidAtTheProcessedSizeNamesItsViewId) {
  replaceCamLine(1, 8, "713.189 0.0 0.0");  // principal point on the left border
  expectFailure("--views 0", "view 1 (", "at 120x82: principal point");
}

// Textureless images: every pixel is unscored (NaN), which used to exit 0.
TEST_F(DepthCli, AllInvalidResultIsAnError) {
  for (const char* view : {"00000000", "00000001"}) {
    fs::remove(input_ + "/images/" + view + ".png");
    writePnm(input_ + "/images/" + view + ".pgm", ImageU8(707, 481, 1, 128));
  }
  expectFailure("", "no valid depth in any of the 2 depth maps (19680 pixels)",
                "check the cameras, depth ranges and options");
}

TEST_F(DepthCli, OutputDirectoryErrorsSayWhy) {
  test::TempDir::writeTo(dir_.file("file"), "a file where a folder is expected");
  output_ = dir_.file("file/out");
  expectFailure("", "file: cannot create directory", "(a file that is not a directory is in the way)");
}

}  // namespace
}  // namespace amhmvs

namespace amhmvs {
namespace {

// A real COLMAP workspace made by `colmap image_undistorter` (binary model;
// scripts/make_colmap_model.sh also writes the text model beside it).
TEST(DepthCliColmap, DepthMapsFromARealColmapWorkspace) {
  const char* workspace = std::getenv("AMHMVS_COLMAP_WORKSPACE");
  if (!workspace) GTEST_SKIP() << "AMHMVS_COLMAP_WORKSPACE not set (scripts/run_tests.sh sets it)";
  test::TempDir out;
  const CommandResult r = runDepth(std::string(workspace) + " " + out.path() +
                                   " --backend cpu --max_image_size 256 --iterations 3 "
                                   "--num_sources 4 --views 1,6");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* view : {"00000001", "00000006"}) {
    const ImageF depth = readPfm(out.path() + "/" + view + "/depth.pfm");
    PinholeCamera camera;
    double dmin, dmax;
    readMvsnetCam(out.path() + "/" + view + "/cam.txt", &camera, &dmin, &dmax);
    EXPECT_EQ(depth.width, 256);
    long inside = 0;
    for (float d : depth.data) inside += std::isfinite(d) && d >= dmin && d <= dmax;
    EXPECT_GT(inside, 0.9 * depth.data.size()) << view;
  }
}

}  // namespace
}  // namespace amhmvs
