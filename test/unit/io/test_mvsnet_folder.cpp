// MVSNet dense folder reading and cam writing (io/mvsnet_folder.h).
#include "amhmvs_mapping/io/mvsnet_folder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

const char* const kExtrinsic =
    "extrinsic\n"
    "1 0 0 0.5\n"
    "0 1 0 -0.25\n"
    "0 0 1 2\n"
    "0 0 0 1\n"
    "\n";

std::string camText(const std::string& intrinsic_rows, const std::string& depth_line) {
  return std::string(kExtrinsic) + "intrinsic\n" + intrinsic_rows + "\n" + depth_line + "\n";
}

const char* const kK = "100 0 31.5\n0 110 23.5\n0 0 1\n";

// A valid 3-view folder with 64x48 PGM images; individual files are then broken.
void makeFolder(const test::TempDir& tmp) {
  for (int id = 0; id < 3; ++id) {
    char name[64];
    std::snprintf(name, sizeof(name), "images/%08d.pgm", id);
    std::filesystem::create_directories(tmp.file("images"));
    writePnm(tmp.file(name), ImageU8(64, 48, 1, 100));
    std::snprintf(name, sizeof(name), "cams/%08d_cam.txt", id);
    tmp.write(name, camText(kK, "1.0 0.5 9"));
  }
  tmp.write("pair.txt", "3\n0\n2 1 10.5 2 3\n1\n1 0 10.5\n2\n1 0 3\n");
}

TEST(MvsnetFolder, ReadsRealFountainQuarter) {
  AMHMVS_REQUIRE_DATA(dir, "mvsnet/fountain_x0.25");
  const Scene scene = readMvsnetDenseFolder(dir);
  ASSERT_EQ(scene.views.size(), 11u);
  for (size_t i = 0; i < scene.views.size(); ++i) {
    const SceneView& v = scene.views[i];
    EXPECT_EQ(v.id, static_cast<int>(i));
    EXPECT_EQ(v.camera.width, 768);
    EXPECT_EQ(v.camera.height, 512);
    EXPECT_TRUE(v.camera.validate().empty());
    EXPECT_TRUE(std::filesystem::exists(v.image_path));
    EXPECT_LT(v.depth_min, v.depth_max);
  }
  const SceneView& v0 = scene.views[0];
  EXPECT_EQ(v0.name, "00000000.png");
  EXPECT_DOUBLE_EQ(v0.camera.fx, 689.87);
  EXPECT_DOUBLE_EQ(v0.camera.fy, 691.04);
  EXPECT_DOUBLE_EQ(v0.camera.cx, 379.7975);
  EXPECT_DOUBLE_EQ(v0.camera.cy, 251.3275);
  EXPECT_DOUBLE_EQ(v0.camera.R(0, 1), -0.892535);
  EXPECT_DOUBLE_EQ(v0.camera.t(2), -9.844835206812);
  EXPECT_DOUBLE_EQ(v0.depth_min, 5.169322);
  EXPECT_DOUBLE_EQ(v0.depth_max, 18.485516);
  ASSERT_EQ(scene.sources.size(), 11u);
  const auto& s0 = scene.sources.at(0);
  ASSERT_EQ(s0.size(), 10u);
  EXPECT_EQ(s0[0].view_id, 1);
  EXPECT_DOUBLE_EQ(s0[0].score, 1343);
  EXPECT_EQ(s0[1].view_id, 2);
  EXPECT_DOUBLE_EQ(s0[1].score, 966);
  EXPECT_EQ(scene.sources.at(1)[0].view_id, 2);
}

TEST(MvsnetFolder, ReadsSyntheticFolder) {
  test::TempDir tmp;
  makeFolder(tmp);
  const Scene scene = readMvsnetDenseFolder(tmp.path());
  ASSERT_EQ(scene.views.size(), 3u);
  const SceneView& v = scene.views[2];
  EXPECT_EQ(v.id, 2);
  EXPECT_EQ(v.camera.width, 64);
  EXPECT_EQ(v.camera.height, 48);
  EXPECT_EQ(v.camera.fy, 110);
  EXPECT_EQ(v.camera.t(0), 0.5);
  EXPECT_DOUBLE_EQ(v.depth_max, 1.0 + 0.5 * 8);
  ASSERT_EQ(scene.sources.at(0).size(), 2u);
  EXPECT_EQ(scene.sources.at(0)[1].view_id, 2);
  EXPECT_EQ(scene.sources.at(0)[1].score, 3);
}

TEST(MvsnetFolder, DepthLineVariantsAndTolerantWhitespace) {
  test::TempDir tmp;
  PinholeCamera cam;
  double lo = 0, hi = 0;
  // Two numbers: depth_num defaults to 192.
  readMvsnetCam(tmp.write("a.txt", camText(kK, "2 0.1")), &cam, &lo, &hi);
  EXPECT_DOUBLE_EQ(lo, 2);
  EXPECT_DOUBLE_EQ(hi, 2 + 0.1 * 191);
  readMvsnetCam(tmp.write("b.txt", camText(kK, "2 0.1 11")), &cam, &lo, &hi);
  EXPECT_DOUBLE_EQ(hi, 3);
  readMvsnetCam(tmp.write("c.txt", camText(kK, "2 0.1 192 7.5")), &cam, &lo, &hi);
  EXPECT_DOUBLE_EQ(hi, 7.5);
  // Extra blank lines, trailing spaces and CRLF line ends.
  readMvsnetCam(tmp.write("d.txt",
                          "\r\n\nextrinsic  \r\n1 0 0 0.5  \r\n0 1 0 -0.25\r\n0 0 1 2\r\n"
                          "0 0 0 1\r\n\r\n\r\nintrinsic\r\n100 0 31.5 \r\n0 110 23.5\r\n"
                          "0 0 1\r\n\r\n\r\n  2 0.1 192 7.5  \r\n\r\n\r\n"),
                &cam, &lo, &hi);
  EXPECT_EQ(cam.fx, 100);
  EXPECT_EQ(cam.cy, 23.5);
  EXPECT_EQ(cam.t(1), -0.25);
  EXPECT_DOUBLE_EQ(hi, 7.5);
}

TEST(MvsnetFolder, WriteCamRoundTrip) {
  test::TempDir tmp;
  PinholeCamera cam;
  cam.fx = 689.87123456789;
  cam.fy = 691.04;
  cam.cx = 379.7975;
  cam.cy = 251.3275;
  cam.width = 768;
  cam.height = 512;
  cam.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  cam.t = Eigen::Vector3d(-3.48046703877, -1.19648323, -9.8448352068);
  writeMvsnetCam(tmp.file("w_cam.txt"), cam, 5.169322, 18.485516);
  PinholeCamera back;
  double lo = 0, hi = 0;
  readMvsnetCam(tmp.file("w_cam.txt"), &back, &lo, &hi);
  EXPECT_NEAR(back.fx, cam.fx, 1e-8 * cam.fx);
  EXPECT_EQ(back.fy, cam.fy);
  EXPECT_EQ(back.cx, cam.cx);
  EXPECT_LT((back.R - cam.R).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((back.t - cam.t).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_EQ(lo, 5.169322);
  EXPECT_EQ(hi, 18.485516);
  EXPECT_INPUT_ERROR(writeMvsnetCam(tmp.file("bad_cam.txt"), cam, 5, 5), "bad_cam.txt",
                     "depth range");
  cam.fx = -1;
  EXPECT_INPUT_ERROR(writeMvsnetCam(tmp.file("neg_cam.txt"), cam, 1, 5), "neg_cam.txt", "focal");
}

TEST(MvsnetFolder, MalformedCamFilesNameFileLineAndProblem) {
  test::TempDir tmp;
  PinholeCamera cam;
  double lo, hi;
  auto read = [&](const std::string& name, const std::string& text) {
    readMvsnetCam(tmp.write(name, text), &cam, &lo, &hi);
  };
  EXPECT_INPUT_ERROR(read("k_cam.txt", camText("100 0 31.5\nabc 110 23.5\n0 0 1\n", "1 1")),
                     "k_cam.txt: line 9", "expected 3 numbers for intrinsic row, got 'abc");
  EXPECT_INPUT_ERROR(read("short_cam.txt", camText("100 0 31.5\n0 110\n0 0 1\n", "1 1")),
                     "short_cam.txt: line 9", "got 2");
  EXPECT_INPUT_ERROR(read("kw_cam.txt", "extrinsics\n"), "kw_cam.txt: line 1", "'extrinsic'");
  EXPECT_INPUT_ERROR(read("ext_cam.txt", "extrinsic\n1 0 0\n"), "ext_cam.txt: line 2",
                     "extrinsic row");
  EXPECT_INPUT_ERROR(read("bottom_cam.txt",
                          "extrinsic\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\nintrinsic\n" +
                              std::string(kK) + "1 1\n"),
                     "bottom_cam.txt", "0 0 0 1");
  EXPECT_INPUT_ERROR(read("skew_cam.txt", camText("100 0.5 31.5\n0 110 23.5\n0 0 1\n", "1 1")),
                     "skew_cam.txt", "skew");
  EXPECT_INPUT_ERROR(read("row_cam.txt", camText("100 0 31.5\n0 110 23.5\n0 0 2\n", "1 1")),
                     "row_cam.txt", "0 0 1");
  EXPECT_INPUT_ERROR(read("inv_cam.txt", camText(kK, "5 1 192 4")), "inv_cam.txt",
                     "depth range");
  EXPECT_INPUT_ERROR(read("neg_cam.txt", camText(kK, "-1 0.1")), "neg_cam.txt", "depth range");
  EXPECT_INPUT_ERROR(read("zero_cam.txt", camText(kK, "1 0")), "zero_cam.txt", "depth range");
  EXPECT_INPUT_ERROR(read("nan_cam.txt", camText(kK, "nan 0.1")), "nan_cam.txt",
                     "not a finite number");
  EXPECT_INPUT_ERROR(read("inf_cam.txt", camText(kK, "1 0.1 192 inf")), "inf_cam.txt",
                     "not a finite number");
  EXPECT_INPUT_ERROR(read("num_cam.txt", camText(kK, "1 0.1 1")), "num_cam.txt", "depth_num");
  EXPECT_INPUT_ERROR(read("nodepth_cam.txt", camText(kK, "")), "nodepth_cam.txt",
                     "end of file");
  EXPECT_INPUT_ERROR(read("extra_cam.txt", camText(kK, "1 1\nmore")), "extra_cam.txt",
                     "unexpected content");
  EXPECT_INPUT_ERROR(read("many_cam.txt", camText(kK, "1 1 2 3 4")), "many_cam.txt",
                     "2 to 4 numbers");
}

// Bytes of a binary file given as a cam file are shown escaped, never raw.
TEST(MvsnetFolder, GarbageBytesAreEscapedInMessages) {
  test::TempDir tmp;
  PinholeCamera cam;
  double lo, hi;
  try {
    readMvsnetCam(tmp.write("bin_cam.txt", std::string("\x7f" "ELF\x01\x1b[2J\xff\n")), &cam, &lo, &hi);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("got '\\x7fELF\\x01\\x1b[2J\\xff'"), std::string::npos) << message;
    for (const char c : message) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << static_cast<int>(c);
  }
}

// Finite cameras and ranges the float estimator cannot use are refused at load.
TEST(MvsnetFolder, IllConditionedCamerasAreRefused) {
  const std::string far = "extrinsic\n1 0 0 1e12\n0 1 0 0\n0 0 1 0\n0 0 0 1\nintrinsic\n";
  struct Case {
    std::string cam, needle;
  } cases[] = {
      {camText("0.01 0 31.5\n0 0.01 23.5\n0 0 1\n", "1.0 0.5 9"), "focal length (fx=0.01"},
      {camText("1e6 0 31.5\n0 1e6 23.5\n0 0 1\n", "1.0 0.5 9"), "times the longest image side (64 px)"},
      {camText(kK, "1e-20 1e-21 9"), "depth range [1e-20"},
      {camText(kK, "1 1e20"), "outside 1e-12..1e+12"},
      {far + kK + "\n1.0 0.5 9\n", "camera centre is 1e+12 from the world origin"},
  };
  for (const Case& c : cases) {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("cams/00000002_cam.txt", c.cam);
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "00000002_cam.txt", c.needle);
  }
  // Just inside the limits: f slightly above 1e-3 and below 1e4 times the side.
  test::TempDir tmp;
  makeFolder(tmp);
  tmp.write("cams/00000002_cam.txt", camText("0.065 0 31.5\n0 639000 23.5\n0 0 1\n", "1.0 0.5 9"));
  EXPECT_EQ(readMvsnetDenseFolder(tmp.path()).views.size(), 3u);
}

TEST(MvsnetFolder, MalformedFoldersNameFileAndProblem) {
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("cams/00000001_cam.txt",
              "extrinsic\n1 0 0 0\n0 2 0 0\n0 0 1 0\n0 0 0 1\nintrinsic\n" + std::string(kK) +
                  "1 1\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "00000001_cam.txt", "rotation");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    writePnm(tmp.file("images/00000001.ppm"), ImageU8(64, 48, 3));
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "images", "share view id 1");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    std::filesystem::remove(tmp.file("images/00000002.pgm"));
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "00000002_cam.txt", "no image");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("cams/2_cam.txt", camText(kK, "1 1"));
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "cams", "share view id 2");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n0\n1 7 3.0\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt", "source view 7");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n9\n1 1 3.0\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt", "reference view 9");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n0\n2 1 3.0 0 1.0\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt: line 3", "itself");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "2\n0\n1 1 3.0\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt", "end of file");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n0\n1 1 high\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt: line 3", "score");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n0\n2 1 3.0 1 2.0\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt", "repeats");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("pair.txt", "1\n0\n1 1 3.0\n5\n");
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "pair.txt: line 4",
                       "unexpected content");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    tmp.write("images/00000001.png", "\x89PNG\r\n\x1a\n");  // an unreadable header
    std::filesystem::remove(tmp.file("images/00000001.pgm"));
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "00000001.png", "corrupt PNG");
  }
  {
    test::TempDir tmp;
    makeFolder(tmp);
    for (int i = 0; i < 3; ++i) {
      std::filesystem::remove(tmp.file("cams/0000000" + std::to_string(i) + "_cam.txt"));
    }
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "cams", "no cam files");
  }
  {
    test::TempDir tmp;
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.file("nope")), "nope", "not a directory");
    std::filesystem::create_directories(tmp.file("images"));
    EXPECT_INPUT_ERROR(readMvsnetDenseFolder(tmp.path()), "cams", "missing");
  }
}

TEST(MvsnetFolder, MissingPairFileLeavesSourcesEmpty) {
  test::TempDir tmp;
  makeFolder(tmp);
  std::filesystem::remove(tmp.file("pair.txt"));
  const Scene scene = readMvsnetDenseFolder(tmp.path());
  EXPECT_EQ(scene.views.size(), 3u);
  EXPECT_TRUE(scene.sources.empty());
}

}  // namespace
}  // namespace amhmvs
