#include "amhmvs_mapping/simulation/synthetic_scene.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace amhmvs {
namespace {

// Set AMHMVS_SYNTH_DUMP_DIR to write the rendered test images as PPM files.
void maybeDump(const ImageU8& image, const std::string& name) {
  const char* dir = std::getenv("AMHMVS_SYNTH_DUMP_DIR");
  if (dir == nullptr || image.channels != 3) return;
  const std::string path = std::string(dir) + "/" + name + ".ppm";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return;
  std::fprintf(f, "P6\n%d %d\n255\n", image.width, image.height);
  std::fwrite(image.data.data(), 1, image.data.size(), f);
  std::fclose(f);
}

double grey(const ImageU8& im, int x, int y) {
  return 0.299 * im.at(x, y, 0) + 0.587 * im.at(x, y, 1) + 0.114 * im.at(x, y, 2);
}

double bilinearGrey(const ImageU8& im, double u, double v) {
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  const double fx = u - x0, fy = v - y0;
  return (1 - fx) * (1 - fy) * grey(im, x0, y0) + fx * (1 - fy) * grey(im, x0 + 1, y0) +
         (1 - fx) * fy * grey(im, x0, y0 + 1) + fx * fy * grey(im, x0 + 1, y0 + 1);
}

// Standard deviation of grey values in the (2r+1)^2 window around (x, y).
double localStd(const ImageU8& im, int x, int y, int r) {
  double s = 0, s2 = 0;
  int n = 0;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const int xx = std::min(im.width - 1, std::max(0, x + dx));
      const int yy = std::min(im.height - 1, std::max(0, y + dy));
      const double g = grey(im, xx, yy);
      s += g;
      s2 += g * g;
      ++n;
    }
  }
  const double mean = s / n;
  return std::sqrt(std::max(0.0, s2 / n - mean * mean));
}

// True when the depth in the 3x3 window around (x, y) is finite and lies on
// one smooth surface (no depth discontinuity).
bool smoothDepth(const ImageF& depth, int x, int y) {
  if (x < 1 || y < 1 || x >= depth.width - 1 || y >= depth.height - 1) return false;
  const double d = depth.at(x, y);
  if (!std::isfinite(d)) return false;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const double a = depth.at(x + dx, y + dy), b = depth.at(x - dx, y - dy);
      if (!std::isfinite(a) || !std::isfinite(b)) return false;
      if (std::abs(a + b - 2 * d) > 1e-3 * d) return false;  // second difference
    }
  }
  return true;
}

struct ConsistencyStats {
  int valid0 = 0;           // pixels of view 0 with finite depth
  int in_view = 0;          // ...projecting inside view 1
  int visible = 0;          // ...and not occluded there
  int depth_mismatch = 0;   // visible, not grazing, with |z_hit - z| > 1e-4 z
  int raster_mismatch = 0;  // view 1's depth image differs from depthAt at its pixel
  int compared = 0;         // pixels used for the intensity comparison
  double mean_abs_diff = 0; // mean |grey0 - grey1| over those
};

// Backprojects every pixel of view 0 with its ground-truth depth and checks
// it against the geometry and image of view 1.
ConsistencyStats checkConsistency(const SyntheticWorld& world, const RenderedView& v0,
                                  const RenderedView& v1) {
  ConsistencyStats st;
  const PinholeCamera& c0 = v0.camera;
  const PinholeCamera& c1 = v1.camera;
  double diff_sum = 0;
  for (int y = 0; y < c0.height; ++y) {
    for (int x = 0; x < c0.width; ++x) {
      const double d0 = v0.depth.at(x, y);
      if (!std::isfinite(d0)) continue;
      ++st.valid0;
      const Eigen::Vector3d world_point =
          c0.R.transpose() * (c0.backproject(x, y, d0) - c0.t);
      const Eigen::Vector3d p1 = c1.toCamera(world_point);
      if (p1.z() <= 0) continue;
      const Eigen::Vector2d uv = c1.project(p1);
      if (!c1.contains(uv)) continue;
      ++st.in_view;
      const double z_hit = depthAt(world, c1, uv.x(), uv.y());
      if (!std::isfinite(z_hit)) {
        ++st.depth_mismatch;
        continue;
      }
      if (z_hit < p1.z() * (1 - 1e-3)) continue;  // occluded in view 1
      ++st.visible;
      // Exactness, except at grazing incidence (|cos| < 0.1) where the float
      // depth's rounding moves the backprojected point visibly off the surface.
      const Eigen::Vector3d n0(v0.normal.at(x, y, 0), v0.normal.at(x, y, 1),
                               v0.normal.at(x, y, 2));
      const bool grazing = std::abs(n0.dot(c0.backproject(x, y, 1.0).normalized())) < 0.1;
      if (!grazing && std::abs(z_hit - p1.z()) > 1e-4 * p1.z()) ++st.depth_mismatch;

      const int xi = static_cast<int>(std::lround(uv.x()));
      const int yi = static_cast<int>(std::lround(uv.y()));
      const double raster = v1.depth.at(xi, yi);
      const double exact = depthAt(world, c1, xi, yi);
      if (!(std::abs(raster - exact) <= 1e-6 * exact)) ++st.raster_mismatch;

      // Intensity comparison away from depth edges, image borders and weak texture.
      const int x1 = static_cast<int>(std::floor(uv.x())), y1 = static_cast<int>(std::floor(uv.y()));
      if (!smoothDepth(v0.depth, x, y) || !smoothDepth(v1.depth, x1, y1) ||
          !smoothDepth(v1.depth, x1 + 1, y1 + 1))
        continue;
      if (std::abs(v1.depth.at(x1, y1) - p1.z()) > 0.02 * p1.z()) continue;
      if (localStd(v0.image, x, y, 3) < 8.0) continue;
      diff_sum += std::abs(grey(v0.image, x, y) - bilinearGrey(v1.image, uv.x(), uv.y()));
      ++st.compared;
    }
  }
  st.mean_abs_diff = st.compared > 0 ? diff_sum / st.compared : 1e9;
  return st;
}

TEST(SyntheticScene, SlantedPlanesGroundTruthIsConsistentBetweenViews) {
  const SyntheticWorld world = makeSlantedPlanesWorld(7);
  const std::vector<PinholeCamera> cams = makeSidewaysCameras(3, 320, 240);
  ASSERT_EQ(cams.size(), 3u);
  const RenderedView v0 = renderView(world, cams[0]);
  maybeDump(v0.image, "slanted_0");
  const int total = cams[0].width * cams[0].height;
  for (int k = 1; k < 3; ++k) {
    const RenderedView vk = renderView(world, cams[k]);
    maybeDump(vk.image, "slanted_" + std::to_string(k));
    const ConsistencyStats st = checkConsistency(world, v0, vk);
    SCOPED_TRACE("view " + std::to_string(k));
    EXPECT_GT(st.valid0, 0.95 * total);
    EXPECT_GT(st.visible, 0.85 * total);
    EXPECT_EQ(st.depth_mismatch, 0);
    EXPECT_EQ(st.raster_mismatch, 0);
    EXPECT_GT(st.compared, 0.6 * total);
    EXPECT_LT(st.mean_abs_diff, 4.0);
    std::printf("slanted view 0 -> %d: valid %.3f visible %.3f compared %d mean |diff| %.3f\n",
                k, double(st.valid0) / total, double(st.visible) / total, st.compared,
                st.mean_abs_diff);
  }
}

TEST(SyntheticScene, IndoorGroundTruthIsConsistentBetweenFrames) {
  const SyntheticWorld world = makeIndoorRoomWorld(3);
  const std::vector<PinholeCamera> cams = makeSmoothTrajectory(20, 320, 240, 3);
  const RenderedView v0 = renderView(world, cams[8]);
  const RenderedView v1 = renderView(world, cams[10]);
  maybeDump(v0.image, "indoor_8");
  maybeDump(v1.image, "indoor_10");
  const int total = cams[0].width * cams[0].height;
  const ConsistencyStats st = checkConsistency(world, v0, v1);
  EXPECT_EQ(st.valid0, total);  // closed room: every ray hits something
  EXPECT_GT(st.visible, 0.7 * total);
  EXPECT_EQ(st.depth_mismatch, 0);
  EXPECT_EQ(st.raster_mismatch, 0);
  EXPECT_LT(st.mean_abs_diff, 4.0);
  std::printf("indoor 8 -> 10: visible %.3f compared %d mean |diff| %.3f\n",
              double(st.visible) / total, st.compared, st.mean_abs_diff);
}

bool sameBytes(const RenderedView& a, const RenderedView& b) {
  return a.image.data == b.image.data && a.depth.data.size() == b.depth.data.size() &&
         a.normal.data.size() == b.normal.data.size() &&
         std::memcmp(a.depth.data.data(), b.depth.data.data(),
                     a.depth.data.size() * sizeof(float)) == 0 &&
         std::memcmp(a.normal.data.data(), b.normal.data.data(),
                     a.normal.data.size() * sizeof(float)) == 0;
}

TEST(SyntheticScene, RenderingIsDeterministic) {
  const SyntheticWorld world = makeIndoorRoomWorld(11);
  const PinholeCamera cam = makeSmoothTrajectory(5, 160, 120, 11)[2];
  const RenderedView a = renderView(world, cam);
  const RenderedView b = renderView(makeIndoorRoomWorld(11), cam);
  EXPECT_TRUE(sameBytes(a, b));
#ifdef _OPENMP
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const RenderedView c = renderView(world, cam);
  omp_set_num_threads(threads);
  EXPECT_TRUE(sameBytes(a, c));
  omp_set_num_threads(3);
  const RenderedView d = renderView(world, cam);
  omp_set_num_threads(threads);
  EXPECT_TRUE(sameBytes(a, d));
#endif
  // Another seed gives another scene.
  const RenderedView e = renderView(makeIndoorRoomWorld(12), cam);
  EXPECT_NE(a.image.data, e.image.data);
}

void expectNormalsUnitAndFacing(const RenderedView& view) {
  const PinholeCamera& cam = view.camera;
  int checked = 0, bad = 0;
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      if (!std::isfinite(view.depth.at(x, y))) {
        EXPECT_TRUE(std::isnan(view.normal.at(x, y, 0)));
        continue;
      }
      const Eigen::Vector3d n(view.normal.at(x, y, 0), view.normal.at(x, y, 1),
                              view.normal.at(x, y, 2));
      const Eigen::Vector3d ray = cam.backproject(x, y, 1.0);
      ++checked;
      if (!(std::abs(n.norm() - 1.0) < 1e-5) || !(n.dot(ray) < 0)) ++bad;
    }
  }
  EXPECT_GT(checked, 0);
  EXPECT_EQ(bad, 0);
}

TEST(SyntheticScene, NormalsAreUnitAndFaceTheCamera) {
  {
    const SyntheticWorld world = makeIndoorRoomWorld(5);
    for (const PinholeCamera& cam : makeSmoothTrajectory(3, 160, 120, 5)) {
      expectNormalsUnitAndFacing(renderView(world, cam, 1));
    }
  }
  {
    const SyntheticWorld world = makeSlantedPlanesWorld(5);
    for (const PinholeCamera& cam : makeSidewaysCameras(3, 160, 120)) {
      expectNormalsUnitAndFacing(renderView(world, cam, 1));
    }
  }
}

TEST(SyntheticScene, SphereNormalIsRadial) {
  SyntheticWorld world;
  SyntheticSphere ball;
  ball.center = {0.2, -0.1, 3.0};
  ball.radius = 0.8;
  world.spheres.push_back(ball);
  const PinholeCamera cam = makeSidewaysCameras(1, 96, 72)[0];
  const RenderedView view = renderView(world, cam, 1);
  int hits = 0;
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const double d = view.depth.at(x, y);
      if (!std::isfinite(d)) {
        EXPECT_EQ(view.image.at(x, y, 0), 0);  // background is black
        continue;
      }
      ++hits;
      const Eigen::Vector3d p = cam.backproject(x, y, d);
      const Eigen::Vector3d c = cam.toCamera(ball.center);
      EXPECT_NEAR((p - c).norm(), ball.radius, 1e-5);
      const Eigen::Vector3d expected = (p - c).normalized();
      EXPECT_NEAR(view.normal.at(x, y, 0), expected.x(), 1e-4);
      EXPECT_NEAR(view.normal.at(x, y, 1), expected.y(), 1e-4);
      EXPECT_NEAR(view.normal.at(x, y, 2), expected.z(), 1e-4);
    }
  }
  EXPECT_GT(hits, 500);
}

TEST(SyntheticScene, DepthMatchesAnalyticPlanes) {
  PinholeCamera cam = test::centredCamera(64, 48, 50);
  // Fronto-parallel infinite plane z = 3 in a camera at the world origin.
  SyntheticWorld world;
  SyntheticPlane wall;
  wall.origin = {0, 0, 3};
  wall.bounded = false;
  world.planes.push_back(wall);
  RenderedView view = renderView(world, cam);
  for (const auto& px : std::vector<std::pair<int, int>>{{0, 0}, {10, 40}, {31, 23}, {63, 47}}) {
    EXPECT_NEAR(view.depth.at(px.first, px.second), 3.0, 1e-6);
    EXPECT_NEAR(view.normal.at(px.first, px.second, 2), -1.0, 1e-6);
  }

  // Moved camera: a bounded fronto-parallel quad at world z = 5 seen from
  // (0.3, -0.2, 1) has depth 4; pixels outside the quad see nothing.
  world.planes[0].origin = {-1, -1, 5};
  world.planes[0].axis_u = {2, 0, 0};
  world.planes[0].axis_v = {0, 2, 0};
  world.planes[0].bounded = true;
  cam.t = -Eigen::Vector3d(0.3, -0.2, 1.0);
  view = renderView(world, cam);
  EXPECT_NEAR(view.depth.at(31, 23), 4.0, 1e-6);
  EXPECT_NEAR(view.depth.at(40, 30), 4.0, 1e-6);
  // Pixel x = 0 looks at world x = 0.3 + (0 - 31.5)/50*4 = -2.22, outside.
  EXPECT_TRUE(std::isnan(view.depth.at(0, 23)));

  // Slanted plane n . X = n . X0, in the camera frame.
  cam.t.setZero();
  const Eigen::Vector3d x0(0.1, 0.2, 2.5);
  const Eigen::Vector3d u(1.0, 0.0, 0.4), v(0.1, 1.0, -0.3);
  const Eigen::Vector3d n = u.cross(v).normalized();
  world.planes[0].origin = x0;
  world.planes[0].axis_u = u;
  world.planes[0].axis_v = v;
  world.planes[0].bounded = false;
  view = renderView(world, cam);
  for (const auto& px : std::vector<std::pair<int, int>>{{0, 0}, {5, 40}, {31, 23}, {60, 10}}) {
    const Eigen::Vector3d ray = cam.backproject(px.first, px.second, 1.0);
    const double expected = n.dot(x0) / n.dot(ray);
    EXPECT_NEAR(view.depth.at(px.first, px.second), expected, 1e-6 * expected);
    const Eigen::Vector3d facing = n.dot(ray) < 0 ? n : Eigen::Vector3d(-n);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(view.normal.at(px.first, px.second, c), facing[c], 1e-6);
    }
  }
}

TEST(SyntheticScene, TextureHasRangeAndLocalContrast) {
  const SyntheticWorld world = makeSlantedPlanesWorld(1);
  const RenderedView view = renderView(world, makeSidewaysCameras(1, 320, 240)[0]);
  int lo = 255, hi = 0, textured = 0;
  double sum = 0, sum2 = 0;
  const int total = view.camera.width * view.camera.height;
  for (int y = 0; y < view.camera.height; ++y) {
    for (int x = 0; x < view.camera.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        lo = std::min<int>(lo, view.image.at(x, y, c));
        hi = std::max<int>(hi, view.image.at(x, y, c));
      }
      const double g = grey(view.image, x, y);
      sum += g;
      sum2 += g * g;
      if (localStd(view.image, x, y, 3) > 8.0) ++textured;
    }
  }
  const double mean = sum / total, sd = std::sqrt(sum2 / total - mean * mean);
  std::printf("grey mean %.1f sd %.1f, range [%d, %d], textured 7x7 fraction %.3f\n", mean, sd,
              lo, hi, double(textured) / total);
  EXPECT_GE(lo, 30);
  EXPECT_LE(hi, 225);
  EXPECT_GT(sd, 25);
  EXPECT_GT(textured, 0.9 * total);

  // A weakly textured surface has little contrast.
  SyntheticWorld weak;
  SyntheticPlane plane;
  plane.origin = {0, 0, 3};
  plane.bounded = false;
  plane.texture_scale = 0.08;
  plane.texture_contrast = 0.1;
  weak.planes.push_back(plane);
  const RenderedView wv = renderView(weak, makeSidewaysCameras(1, 160, 120)[0]);
  int wlo = 255, whi = 0;
  for (uint8_t b : wv.image.data) {
    wlo = std::min<int>(wlo, b);
    whi = std::max<int>(whi, b);
  }
  EXPECT_LE(whi - wlo, 20);
  EXPECT_GT(whi - wlo, 2);
}

TEST(SyntheticScene, CastRayAgreesWithRenderedView) {
  const SyntheticWorld world = makeIndoorRoomWorld(2);
  const PinholeCamera cam = makeSmoothTrajectory(4, 80, 60, 2)[1];
  const RenderedView view = renderView(world, cam, 1);
  for (const auto& px : std::vector<std::pair<int, int>>{{3, 4}, {40, 30}, {70, 50}}) {
    const Eigen::Vector3d dir = cam.R.transpose() * cam.backproject(px.first, px.second, 1.0);
    const RayHit hit = castRay(world, cam.center(), dir);
    ASSERT_TRUE(hit.hit);
    EXPECT_NEAR(hit.s, view.depth.at(px.first, px.second), 1e-5 * hit.s);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(hit.color[c], view.image.at(px.first, px.second, c), 0.5 + 1e-9);
    }
    EXPECT_NEAR(hit.normal.norm(), 1.0, 1e-12);
    EXPECT_LT(hit.normal.dot(dir), 0);
  }
}

TEST(SyntheticScene, TrajectoryIsSmoothAndInsideTheRoom) {
  const std::vector<PinholeCamera> cams = makeSmoothTrajectory(30, 160, 120, 9);
  ASSERT_EQ(cams.size(), 30u);
  for (size_t i = 0; i < cams.size(); ++i) {
    EXPECT_EQ(cams[i].validate(), "");
    const Eigen::Vector3d c = cams[i].center();
    EXPECT_GT(c.x(), 0.3);
    EXPECT_LT(c.x(), 5.7);
    EXPECT_GT(c.y(), 0.3);
    EXPECT_LT(c.y(), 4.7);
    EXPECT_GT(c.z(), 1.0);
    EXPECT_LT(c.z(), 2.0);
    if (i > 0) {
      EXPECT_LT((c - cams[i - 1].center()).norm(), 0.2);
      EXPECT_GT((c - cams[i - 1].center()).norm(), 0.02);
      const double angle = std::acos(std::min(
          1.0, cams[i].viewingDirection().dot(cams[i - 1].viewingDirection())));
      EXPECT_LT(angle, 0.1);
    }
  }
  const std::vector<PinholeCamera> side = makeSidewaysCameras(5, 160, 120, 0.15);
  EXPECT_NEAR((side[1].center() - side[0].center()).norm(), 0.15, 1e-12);
  EXPECT_NEAR((side[2].center() - side[0].center()).norm(), 0.15, 1e-12);
  EXPECT_NEAR((side[4].center() - side[3].center()).norm(), 0.6, 1e-12);
}

TEST(SyntheticScene, RejectsBadInput) {
  const SyntheticWorld world = makeSlantedPlanesWorld(0);
  PinholeCamera bad;
  EXPECT_THROW(renderView(world, bad), InputError);
  const PinholeCamera cam = makeSidewaysCameras(1, 32, 24)[0];
  EXPECT_THROW(renderView(world, cam, 0), InputError);
  SyntheticWorld degenerate;
  SyntheticPlane plane;
  plane.axis_v = plane.axis_u;
  degenerate.planes.push_back(plane);
  EXPECT_THROW(renderView(degenerate, cam), InputError);
  SyntheticWorld bad_sphere;
  bad_sphere.spheres.push_back(SyntheticSphere{});
  bad_sphere.spheres[0].radius = -1;
  EXPECT_THROW(renderView(bad_sphere, cam), InputError);
  EXPECT_THROW(makeLookAtCamera({0, 0, 0}, {0, 0, 1}, {0, 0, 1}, 32, 24), InputError);
}

TEST(SyntheticScene, RendersQuicklyOnOneThread) {
#ifdef _OPENMP
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  const SyntheticWorld room = makeIndoorRoomWorld(4);
  const PinholeCamera room_cam = makeSmoothTrajectory(3, 320, 240, 4)[1];
  const SyntheticWorld planes = makeSlantedPlanesWorld(4);
  const PinholeCamera planes_cam = makeSidewaysCameras(1, 320, 240)[0];
  auto seconds = [](const SyntheticWorld& w, const PinholeCamera& c) {
    const auto start = std::chrono::steady_clock::now();
    const RenderedView v = renderView(w, c, 3);
    const auto end = std::chrono::steady_clock::now();
    EXPECT_EQ(v.image.width, 320);
    return std::chrono::duration<double>(end - start).count();
  };
  const double t_room = seconds(room, room_cam);
  const double t_planes = seconds(planes, planes_cam);
#ifdef _OPENMP
  omp_set_num_threads(threads);
#endif
  std::printf("320x240 x9 rays, one thread: indoor %.3f s, slanted planes %.3f s\n", t_room,
              t_planes);
  EXPECT_LT(t_room, 2.0);  // generous for loaded or unoptimised builds
  EXPECT_LT(t_planes, 2.0);
}

}  // namespace
}  // namespace amhmvs
