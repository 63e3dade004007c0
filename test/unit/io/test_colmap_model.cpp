// COLMAP model reading (io/colmap_model.h): a hand-made model written here as
// both text and binary, and optionally a real workspace made by
// scripts/make_colmap_model.sh (AMHMVS_COLMAP_WORKSPACE=<out_dir>/dense).
#include "amhmvs_mapping/io/colmap_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

// ---- A small model, written by the test in both COLMAP formats ---------------

struct TCamera {
  int id;
  int model_id;  // 0 SIMPLE_PINHOLE, 1 PINHOLE, 2 SIMPLE_RADIAL, 4 OPENCV
  int width, height;
  std::vector<double> params;
};
struct TImage {
  int id;
  Eigen::Quaterniond q;  // world-to-camera
  Eigen::Vector3d t;
  int camera_id;
  std::string name;
};
struct TPoint {
  Eigen::Vector3d xyz;
  std::vector<int> track;  // image ids
};
struct TModel {
  std::vector<TCamera> cameras;
  std::vector<TImage> images;
  std::vector<TPoint> points;
};

const char* modelName(int id) {
  switch (id) {
    case 0: return "SIMPLE_PINHOLE";
    case 1: return "PINHOLE";
    case 2: return "SIMPLE_RADIAL";
    default: return "OPENCV";
  }
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof(b), "%.17g", v);
  return b;
}

void writeText(const TModel& m, const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::ostringstream cams, imgs, pts;
  cams << "# Camera list with one line of data per camera:\n";
  for (const TCamera& c : m.cameras) {
    cams << c.id << ' ' << modelName(c.model_id) << ' ' << c.width << ' ' << c.height;
    for (double p : c.params) cams << ' ' << num(p);
    cams << '\n';
  }
  imgs << "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, ...\n";
  for (const TImage& i : m.images) {
    imgs << i.id << ' ' << num(i.q.w()) << ' ' << num(i.q.x()) << ' ' << num(i.q.y()) << ' '
         << num(i.q.z()) << ' ' << num(i.t.x()) << ' ' << num(i.t.y()) << ' ' << num(i.t.z())
         << ' ' << i.camera_id << ' ' << i.name << '\n';
    // 2D points: one per observed 3D point (positions are irrelevant here);
    // the last image gets an empty line, as COLMAP writes for no points.
    if (&i != &m.images.back()) {
      for (size_t p = 0; p < m.points.size(); ++p) {
        const auto& tr = m.points[p].track;
        if (std::find(tr.begin(), tr.end(), i.id) != tr.end()) imgs << "1.5 2.5 " << p << ' ';
      }
    }
    imgs << '\n';
  }
  pts << "# 3D point list\n";
  for (size_t p = 0; p < m.points.size(); ++p) {
    const TPoint& pt = m.points[p];
    pts << p << ' ' << num(pt.xyz.x()) << ' ' << num(pt.xyz.y()) << ' ' << num(pt.xyz.z())
        << " 10 20 30 0.5";
    for (int id : pt.track) pts << ' ' << id << " 0";
    pts << '\n';
  }
  test::TempDir::writeTo(dir + "/cameras.txt", cams.str());
  test::TempDir::writeTo(dir + "/images.txt", imgs.str());
  test::TempDir::writeTo(dir + "/points3D.txt", pts.str());
}

template <typename T>
void put(std::string* s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // the test host is little-endian like the format
  s->append(b, sizeof(T));
}

void writeBinary(const TModel& m, const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::string cams, imgs, pts;
  put<uint64_t>(&cams, m.cameras.size());
  for (const TCamera& c : m.cameras) {
    put<uint32_t>(&cams, c.id);
    put<int32_t>(&cams, c.model_id);
    put<uint64_t>(&cams, c.width);
    put<uint64_t>(&cams, c.height);
    for (double p : c.params) put<double>(&cams, p);
  }
  put<uint64_t>(&imgs, m.images.size());
  for (const TImage& i : m.images) {
    put<uint32_t>(&imgs, i.id);
    for (double v : {i.q.w(), i.q.x(), i.q.y(), i.q.z(), i.t.x(), i.t.y(), i.t.z()}) {
      put<double>(&imgs, v);
    }
    put<uint32_t>(&imgs, i.camera_id);
    imgs += i.name;
    imgs.push_back('\0');
    std::vector<size_t> seen;
    for (size_t p = 0; p < m.points.size(); ++p) {
      const auto& tr = m.points[p].track;
      if (std::find(tr.begin(), tr.end(), i.id) != tr.end()) seen.push_back(p);
    }
    put<uint64_t>(&imgs, seen.size());
    for (size_t p : seen) {
      put<double>(&imgs, 1.5);
      put<double>(&imgs, 2.5);
      put<int64_t>(&imgs, static_cast<int64_t>(p));
    }
  }
  put<uint64_t>(&pts, m.points.size());
  for (size_t p = 0; p < m.points.size(); ++p) {
    const TPoint& pt = m.points[p];
    put<uint64_t>(&pts, p);
    for (int k = 0; k < 3; ++k) put<double>(&pts, pt.xyz[k]);
    pts += std::string("\x0a\x14\x1e", 3);
    put<double>(&pts, 0.5);
    put<uint64_t>(&pts, pt.track.size());
    for (int id : pt.track) {
      put<uint32_t>(&pts, id);
      put<uint32_t>(&pts, 0);
    }
  }
  test::TempDir::writeTo(dir + "/cameras.bin", cams);
  test::TempDir::writeTo(dir + "/images.bin", imgs);
  test::TempDir::writeTo(dir + "/points3D.bin", pts);
}

// Three overlapping views (ids 1, 2, 5) and one (id 7) that shares no point.
TModel smallModel() {
  TModel m;
  m.cameras.push_back({1, 1, 64, 48, {50, 52, 31.5, 23.5}});
  m.cameras.push_back({3, 0, 64, 48, {55, 31.5, 23.5}});
  auto pose = [](const Eigen::Quaterniond& q, const Eigen::Vector3d& center) {
    return std::make_pair(q, Eigen::Vector3d(-(q.toRotationMatrix() * center)));
  };
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(-0.15, Eigen::Vector3d::UnitY()));
  const std::vector<std::tuple<int, Eigen::Quaterniond, Eigen::Vector3d, int, std::string>> views =
      {{1, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0), 1, "a.pgm"},
       {2, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.4, 0, 0), 1, "sub/b.pgm"},
       {5, turn, Eigen::Vector3d(1.5, 0, 0), 3, "c.pgm"},
       {7, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -50), 3, "d.pgm"}};
  for (const auto& [id, q, center, cam, name] : views) {
    const auto [qq, t] = pose(q, center);
    m.images.push_back({id, qq, t, cam, name});
  }
  for (int x = -1; x <= 2; ++x) {
    for (int y : {-1, 1}) {
      for (int z : {4, 6, 8}) {
        // Images 1 and 2 see all points; image 5 the right half.
        std::vector<int> track = {2, 1};
        if (x >= 1) track.push_back(5);
        m.points.push_back({Eigen::Vector3d(x * 0.5, y * 0.5, z), track});
      }
    }
  }
  for (int k = 0; k < 12; ++k) {
    m.points.push_back({Eigen::Vector3d(0.1 * k, 0, 20 + k), {7}});
  }
  return m;
}

void writeImages(const TModel& m, const std::string& image_dir) {
  for (const TImage& i : m.images) {
    std::filesystem::create_directories(
        std::filesystem::path(image_dir + "/" + i.name).parent_path());
    writePnm(image_dir + "/" + i.name, ImageU8(64, 48, 1, 50));
  }
}

// Independent expectations from the model itself.
double expectedScore(const TModel& m, int a, int b, const ColmapOptions& o) {
  auto center = [&](int id) {
    for (const TImage& i : m.images) {
      if (i.id == id) return Eigen::Vector3d(-(i.q.toRotationMatrix().transpose() * i.t));
    }
    return Eigen::Vector3d(0, 0, 0);
  };
  double score = 0;
  for (const TPoint& p : m.points) {
    const bool has_a = std::count(p.track.begin(), p.track.end(), a) > 0;
    const bool has_b = std::count(p.track.begin(), p.track.end(), b) > 0;
    if (!has_a || !has_b) continue;
    const Eigen::Vector3d ra = (center(a) - p.xyz).normalized();
    const Eigen::Vector3d rb = (center(b) - p.xyz).normalized();
    const double theta = std::acos(std::clamp(ra.dot(rb), -1.0, 1.0)) * 180 / M_PI;
    const double sigma = theta <= o.theta0_deg ? o.sigma1_deg : o.sigma2_deg;
    score += std::exp(-(theta - o.theta0_deg) * (theta - o.theta0_deg) / (2 * sigma * sigma));
  }
  return score;
}

void expectSameScene(const Scene& a, const Scene& b, double rel_tol) {
  ASSERT_EQ(a.views.size(), b.views.size());
  auto near = [&](double x, double y) { return std::abs(x - y) <= rel_tol * std::abs(x) + 1e-12; };
  for (size_t i = 0; i < a.views.size(); ++i) {
    const SceneView& u = a.views[i];
    const SceneView& v = b.views[i];
    EXPECT_EQ(u.id, v.id);
    EXPECT_EQ(u.name, v.name);
    EXPECT_EQ(u.image_path, v.image_path);
    EXPECT_EQ(u.camera.width, v.camera.width);
    EXPECT_EQ(u.camera.height, v.camera.height);
    EXPECT_TRUE(near(u.camera.fx, v.camera.fx) && near(u.camera.fy, v.camera.fy) &&
                near(u.camera.cx, v.camera.cx) && near(u.camera.cy, v.camera.cy))
        << u.name;
    EXPECT_LE((u.camera.R - v.camera.R).cwiseAbs().maxCoeff(), rel_tol) << u.name;
    EXPECT_LE((u.camera.t - v.camera.t).cwiseAbs().maxCoeff(), rel_tol * 100) << u.name;
    EXPECT_TRUE(near(u.depth_min, v.depth_min) && near(u.depth_max, v.depth_max)) << u.name;
    const auto& su = a.sources.at(u.id);
    const auto& sv = b.sources.at(v.id);
    ASSERT_EQ(su.size(), sv.size()) << u.name;
    for (size_t k = 0; k < su.size(); ++k) {
      EXPECT_EQ(su[k].view_id, sv[k].view_id) << u.name << " source " << k;
      EXPECT_TRUE(near(su[k].score, sv[k].score)) << u.name << " source " << k;
    }
  }
}

// ---- Tests ------------------------------------------------------------------

TEST(ColmapModel, ReadsSmallTextModelExactly) {
  test::TempDir tmp;
  const TModel m = smallModel();
  writeText(m, tmp.file("ws/sparse"));
  writeImages(m, tmp.file("ws/images"));
  const ColmapOptions o;
  const Scene scene = readColmapWorkspace(tmp.file("ws"));
  ASSERT_EQ(scene.views.size(), 4u);
  EXPECT_EQ(scene.views[0].id, 1);
  EXPECT_EQ(scene.views[1].id, 2);
  EXPECT_EQ(scene.views[2].id, 5);
  EXPECT_EQ(scene.views[3].id, 7);
  EXPECT_EQ(scene.views[1].name, "sub/b.pgm");
  EXPECT_EQ(scene.views[1].image_path, tmp.file("ws/images") + "/sub/b.pgm");

  // PINHOLE and SIMPLE_PINHOLE intrinsics.
  const PinholeCamera& c1 = scene.views[0].camera;
  EXPECT_EQ(c1.fx, 50);
  EXPECT_EQ(c1.fy, 52);
  EXPECT_EQ(c1.cx, 31.5);
  EXPECT_EQ(c1.cy, 23.5);
  EXPECT_EQ(c1.width, 64);
  EXPECT_EQ(c1.height, 48);
  const PinholeCamera& c5 = scene.views[2].camera;
  EXPECT_EQ(c5.fx, 55);
  EXPECT_EQ(c5.fy, 55);
  // Pose: world-to-camera from the quaternion; the centre comes back.
  EXPECT_LT((c5.center() - Eigen::Vector3d(1.5, 0, 0)).norm(), 1e-12);
  EXPECT_LT((c5.R - m.images[2].q.toRotationMatrix()).cwiseAbs().maxCoeff(), 1e-12);

  // Depth range of view 1 (identity pose): z in {4, 6, 8}, 8 points each.
  EXPECT_DOUBLE_EQ(scene.views[0].depth_min, 4 * 0.8);
  EXPECT_DOUBLE_EQ(scene.views[0].depth_max, 8 * 1.2);
  // View 7 sits 50 m behind: z = 70..81, quantiles interpolated over 12 points.
  const double lo7 = 70 + 0.01 * 11 * 1.0, hi7 = 70 + 0.99 * 11 * 1.0;
  EXPECT_NEAR(scene.views[3].depth_min, lo7 * 0.8, 1e-9);
  EXPECT_NEAR(scene.views[3].depth_max, hi7 * 1.2, 1e-9);

  // Sources: ranked by the MVSNet score; view 7 shares nothing.
  const auto& s1 = scene.sources.at(1);
  ASSERT_EQ(s1.size(), 2u);
  const double s12 = expectedScore(m, 1, 2, o), s15 = expectedScore(m, 1, 5, o);
  EXPECT_EQ(s1[0].view_id, s12 > s15 ? 2 : 5);
  EXPECT_NEAR(s1[0].score, std::max(s12, s15), 1e-9);
  EXPECT_NEAR(s1[1].score, std::min(s12, s15), 1e-9);
  EXPECT_NEAR(scene.sources.at(2)[0].score + scene.sources.at(2)[1].score,
              expectedScore(m, 2, 1, o) + expectedScore(m, 2, 5, o), 1e-9);
  ASSERT_EQ(scene.sources.at(5).size(), 2u);
  EXPECT_TRUE(scene.sources.at(7).empty());
  for (const auto& [ref, list] : scene.sources) {
    for (const SourceCandidate& s : list) {
      EXPECT_NE(s.view_id, ref);
      EXPECT_GT(s.score, 0);
    }
  }
}

TEST(ColmapModel, BinaryAndTextGiveTheSameScene) {
  test::TempDir tmp;
  const TModel m = smallModel();
  writeText(m, tmp.file("ws/sparse/0"));
  writeBinary(m, tmp.file("ws/sparse/0"));
  writeImages(m, tmp.file("ws/images"));
  ColmapOptions o;
  o.format = ColmapOptions::Format::kText;
  const Scene text = readColmapWorkspace(tmp.file("ws"), o);  // sparse/0 layout
  o.format = ColmapOptions::Format::kBinary;
  const Scene binary = readColmapWorkspace(tmp.file("ws"), o);
  expectSameScene(text, binary, 0.0);
  // Sparse dir and image dir given separately.
  const Scene direct = readColmapModel(tmp.file("ws/sparse/0"), tmp.file("ws/images"));
  expectSameScene(binary, direct, 0.0);
}

TEST(ColmapModel, OptionsChangeRangesAndSources) {
  test::TempDir tmp;
  const TModel m = smallModel();
  writeBinary(m, tmp.file("ws/sparse"));
  writeImages(m, tmp.file("ws/images"));
  ColmapOptions o;
  o.max_sources = 1;
  o.depth_min_scale = 1.0;
  o.depth_max_scale = 1.0;
  o.depth_low_percentile = 0.5;
  const Scene scene = readColmapWorkspace(tmp.file("ws"), o);
  EXPECT_DOUBLE_EQ(scene.views[0].depth_min, 6);  // median of {4 x8, 6 x8, 8 x8}
  EXPECT_DOUBLE_EQ(scene.views[0].depth_max, 8);
  for (const auto& [ref, list] : scene.sources) EXPECT_LE(list.size(), 1u) << ref;
  o.min_points = 30;
  EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws"), o), "a.pgm", "sparse points");
  o = ColmapOptions();
  o.sigma1_deg = 0;
  EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws"), o), "ColmapOptions", "sigma1_deg");
}

TEST(ColmapModel, MalformedModelsNameFileAndProblem) {
  const TModel good = smallModel();
  auto workspace = [&](const test::TempDir& tmp, const TModel& m, bool binary) {
    if (binary) {
      writeBinary(m, tmp.file("ws/sparse"));
    } else {
      writeText(m, tmp.file("ws/sparse"));
    }
    writeImages(good, tmp.file("ws/images"));
    return tmp.file("ws");
  };
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "text");
    const std::string cams = binary ? "cameras.bin" : "cameras.txt";
    const std::string imgs = binary ? "images.bin" : "images.txt";
    const std::string pts = binary ? "points3D.bin" : "points3D.txt";
    {
      test::TempDir tmp;
      TModel m = good;
      m.cameras[1] = {3, 2, 64, 48, {55, 31.5, 23.5, 0.01}};
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), cams,
                         "colmap image_undistorter");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.cameras[0] = {1, 4, 64, 48, {50, 52, 31.5, 23.5, 0, 0, 0, 0}};
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), "OPENCV",
                         "image_undistorter");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.images[1].camera_id = 9;
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), imgs,
                         "unknown camera id 9");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.images[2].name = "missing.pgm";
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), "missing.pgm",
                         "not found");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.points[0].track.push_back(42);
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), pts,
                         "unknown image id 42");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.points.resize(m.points.size() - 3);  // view 7 keeps 9 points
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), "d.pgm",
                         "observes 9 sparse points");
    }
    {
      test::TempDir tmp;
      TModel m = good;
      m.cameras[0].width = 65;  // images on disk are 64 wide
      EXPECT_INPUT_ERROR(readColmapWorkspace(workspace(tmp, m, binary)), "a.pgm",
                         "but its camera is 65x48");
    }
  }
  {
    test::TempDir tmp;
    const std::string ws = workspace(tmp, good, true);
    const std::string path = tmp.file("ws/sparse/points3D.bin");
    std::filesystem::resize_file(path, std::filesystem::file_size(path) - 5);
    EXPECT_INPUT_ERROR(readColmapWorkspace(ws), "points3D.bin", "truncated");
    test::TempDir::writeTo(tmp.file("ws/sparse/images.bin"),
                           std::string("\xff\xff\xff\x7f\0\0\0\0", 8));
    EXPECT_INPUT_ERROR(readColmapWorkspace(ws), "images.bin", "image count 2147483647");
  }
  {
    test::TempDir tmp;
    const std::string ws = workspace(tmp, good, false);
    test::TempDir::writeTo(tmp.file("ws/sparse/cameras.txt"),
                           "# comment\n\n1 PINHOLE 64 48 50 fifty 31.5 23.5\n");
    EXPECT_INPUT_ERROR(readColmapWorkspace(ws), "cameras.txt: line 3", "expected a number");
    test::TempDir::writeTo(tmp.file("ws/sparse/cameras.txt"), "1 PINHOLE 64 48 50 52 31.5\n");
    EXPECT_INPUT_ERROR(readColmapWorkspace(ws), "cameras.txt: line 1", "needs 4 parameters");
    writeText(good, tmp.file("ws/sparse"));
    test::TempDir::writeTo(tmp.file("ws/sparse/images.txt"), "1 1 0 0 0 0 0 0\n\n");
    EXPECT_INPUT_ERROR(readColmapWorkspace(ws), "images.txt: line 1", "IMAGE_ID");
  }
  {
    test::TempDir tmp;
    std::filesystem::create_directories(tmp.file("ws/sparse"));
    EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws")), "ws", "no COLMAP model");
    EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("nope")), "nope", "not a directory");
  }
}

// Ids above INT_MAX in the binary model (uint32 there) used to become
// negative view ids; the text reader already refused them.
TEST(ColmapModel, BinaryIdsAboveIntMaxAreRefused) {
  test::TempDir tmp;
  TModel m = smallModel();
  m.images[3].id = INT_MIN;  // written as uint32 2147483648
  writeBinary(m, tmp.file("ws/sparse"));
  writeImages(m, tmp.file("ws/images"));
  EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws")), "images.bin",
                     "image id 2147483648 out of range (max 2147483647)");
  m = smallModel();
  m.points[0].track.push_back(INT_MIN);
  writeBinary(m, tmp.file("ws/sparse"));
  EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws")), "points3D.bin",
                     "track image id 2147483648 out of range");
}

// Image names are paths relative to images/: '..' or an absolute path would
// read files outside it, even when such a file exists.
TEST(ColmapModel, ImagePathsOutsideTheImageFolderAreRefused) {
  test::TempDir tmp;
  const std::string outside = tmp.file("ws/outside.pgm");
  std::filesystem::create_directories(tmp.file("ws"));
  writePnm(outside, ImageU8(64, 48, 1, 50));
  for (const std::string& name : {std::string("../outside.pgm"), outside,
                                  std::string("sub/../../outside.pgm")}) {
    for (bool binary : {false, true}) {
      TModel m = smallModel();
      writeImages(m, tmp.file("ws/images"));
      m.images[2].name = name;
      if (binary) {
        writeBinary(m, tmp.file("ws/sparse"));
      } else {
        std::filesystem::remove_all(tmp.file("ws/sparse"));
        writeText(m, tmp.file("ws/sparse"));
      }
      EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws")), name,
                         "image name must be a relative path inside the image folder");
    }
  }
}

// A quaternion whose norm overflows used to normalise to a wrong pose, and
// the error then blamed the view's sparse points.
TEST(ColmapModel, QuaternionOfOverflowingNormIsNamed) {
  test::TempDir tmp;
  TModel m = smallModel();
  m.images[0].q = Eigen::Quaterniond(1e300, 1e300, 0, 0);
  writeBinary(m, tmp.file("ws/sparse"));
  writeImages(m, tmp.file("ws/images"));
  EXPECT_INPUT_ERROR(readColmapWorkspace(tmp.file("ws")), "image 1 ('a.pgm')",
                     "invalid rotation quaternion (1e+300, 1e+300, 0, 0), norm 1.41421e+300");
}

// The real model made by scripts/make_colmap_model.sh from the x0.25 fountain.
TEST(ColmapModel, RealWorkspaceBinaryAndTextAgree) {
  const char* env = std::getenv("AMHMVS_COLMAP_WORKSPACE");
  if (env == nullptr || *env == '\0') {
    GTEST_SKIP() << "set AMHMVS_COLMAP_WORKSPACE to <out_dir>/dense of "
                    "scripts/make_colmap_model.sh to test a real COLMAP model";
  }
  ColmapOptions o;
  o.format = ColmapOptions::Format::kBinary;
  const Scene binary = readColmapWorkspace(env, o);
  o.format = ColmapOptions::Format::kText;
  const Scene text = readColmapWorkspace(env, o);
  ASSERT_EQ(binary.views.size(), 11u);
  std::set<std::string> names;
  for (const SceneView& v : binary.views) {
    names.insert(v.name);
    // Undistorted PINHOLE: about 768x512 and fx near the true 690 px.
    EXPECT_NEAR(v.camera.width, 768, 8);
    EXPECT_NEAR(v.camera.height, 512, 8);
    EXPECT_NEAR(v.camera.fx, 690, 70);
    EXPECT_NEAR(v.camera.fx / v.camera.fy, 1.0, 0.02);
    int w = 0, h = 0;
    ASSERT_TRUE(readImageSize(v.image_path, &w, &h));
    EXPECT_EQ(w, v.camera.width);
    // SfM scale is arbitrary: only the ratio is plausible (scene ~4..15 m).
    EXPECT_GT(v.depth_min, 0);
    EXPECT_GT(v.depth_max / v.depth_min, 1.5);
    EXPECT_LT(v.depth_max / v.depth_min, 50);
    EXPECT_FALSE(binary.sources.at(v.id).empty()) << v.name;
  }
  EXPECT_EQ(names.size(), 11u);
  EXPECT_EQ(names.count("00000000.png"), 1u);
  // As in the MVSNet folder's pair.txt (from ground-truth cameras), the first
  // view's best source is its neighbour 00000001.png.
  const SceneView& first = binary.views.front();
  if (first.name == "00000000.png") {
    const int best = binary.sources.at(first.id).front().view_id;
    EXPECT_EQ(binary.views[binary.indexOf(best)].name, "00000001.png");
  }
  // COLMAP writes text with 17 significant digits: both read the same.
  expectSameScene(binary, text, 1e-12);
}

}  // namespace
}  // namespace amhmvs
