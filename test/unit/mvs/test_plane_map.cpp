// Plane maps carried to another camera (mvs/plane_map.h): exact on a plane,
// edge-aware upsampling, z-buffer and cost filter of the reprojection.
#include "amhmvs_mapping/mvs/plane_map.h"

#include <gtest/gtest.h>

#include <cmath>

#include "amhmvs_mapping/core/error.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

// A slanted plane n . X + d = 0 (world frame), seen by cameras near the origin.
const Eigen::Vector3d kNormal = Eigen::Vector3d(0.3, -0.2, -1.0).normalized();
constexpr double kPlaneD = 3.0;

// Depth and normal maps of the plane in `camera`.
PlaneMap planeIn(const PinholeCamera& camera, const Eigen::Vector3d& normal = kNormal, double d = kPlaneD) {
  PlaneMap map{ImageF(camera.width, camera.height, 1), ImageF(camera.width, camera.height, 3)};
  // The plane in camera coordinates: n_c = R n, d_c = d - n_c . t.
  const Eigen::Vector3d n = camera.R * normal;
  const double d_camera = d - n.dot(camera.t);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray = camera.backproject(x, y, 1.0);
      map.depth.at(x, y) = static_cast<float>(-d_camera / n.dot(ray));
      for (int c = 0; c < 3; ++c) map.normal.at(x, y, c) = static_cast<float>(n[c]);
    }
  }
  return map;
}

ImageU8 noiseImage(int width, int height, unsigned seed) {
  ImageU8 image(width, height);
  for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = static_cast<uint8_t>((i * 2654435761u + seed) >> 7);
  return image;
}

TEST(PlaneMap, UpsamplingIsExactOnAPlane) {
  const PinholeCamera fine = test::centredCamera(81, 61, 70.0);
  const PinholeCamera coarse = fine.resized(41, 31);
  const PlaneMap coarse_map = planeIn(coarse);
  const ImageU8 coarse_image = noiseImage(41, 31, 1), fine_image = noiseImage(81, 61, 2);
  const PlaneMap up = resamplePlanes(coarse_map.depth, coarse_map.normal, coarse, coarse_image, fine, fine_image);
  const PlaneMap truth = planeIn(fine);
  ASSERT_TRUE(up.depth.sameSize(81, 61));
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) {
      ASSERT_NEAR(up.depth.at(x, y), truth.depth.at(x, y), 1e-5 * truth.depth.at(x, y)) << x << "," << y;
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(up.normal.at(x, y, c), truth.normal.at(x, y, c), 1e-5);
    }
  }
}

TEST(PlaneMap, UpsamplingFollowsTheFineImageAtADepthEdge) {
  // Coarse: left half at 2 m, right half at 4 m (fronto-parallel); the fine
  // image is dark on the left and bright on the right, edge in the same place.
  const PinholeCamera fine = test::centredCamera(40, 20, 40.0);
  const PinholeCamera coarse = fine.resized(20, 10);
  PlaneMap coarse_map{ImageF(20, 10, 1), ImageF(20, 10, 3, 0.0f)};
  ImageU8 coarse_image(20, 10), fine_image(40, 20);
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 20; ++x) {
      coarse_map.depth.at(x, y) = x < 10 ? 2.0f : 4.0f;
      coarse_map.normal.at(x, y, 2) = -1.0f;
      coarse_image.at(x, y) = x < 10 ? 50 : 200;
    }
  }
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 40; ++x) fine_image.at(x, y) = x < 20 ? 50 : 200;
  const PlaneMap up = resamplePlanes(coarse_map.depth, coarse_map.normal, coarse, coarse_image, fine, fine_image);
  // The fine pixels next to the edge (19 and 20) keep their side's depth: the
  // other side's coarse pixels differ by 150 levels (weight e^-112).
  for (int y = 0; y < 20; ++y) {
    EXPECT_NEAR(up.depth.at(19, y), 2.0f, 1e-4);
    EXPECT_NEAR(up.depth.at(20, y), 4.0f, 1e-4);
  }
  // Without the guide (one grey level everywhere) the edge is blurred.
  const ImageU8 flat_coarse(20, 10, 1, 100), flat_fine(40, 20, 1, 100);
  const PlaneMap blurred = resamplePlanes(coarse_map.depth, coarse_map.normal, coarse, flat_coarse, fine, flat_fine);
  EXPECT_GT(blurred.depth.at(19, 5), 2.1f);
}

TEST(PlaneMap, UpsamplingLeavesNaNWhereNoCoarsePixelHasAPlane) {
  const PinholeCamera fine = test::centredCamera(20, 20, 20.0);
  const PinholeCamera coarse = fine.resized(10, 10);
  PlaneMap coarse_map = planeIn(coarse);
  for (int y = 0; y < 10; ++y)
    for (int x = 5; x < 10; ++x) coarse_map.depth.at(x, y) = std::nanf("");
  const ImageU8 coarse_image(10, 10, 1, 90), fine_image(20, 20, 1, 90);
  const PlaneMap up = resamplePlanes(coarse_map.depth, coarse_map.normal, coarse, coarse_image, fine, fine_image);
  EXPECT_TRUE(std::isnan(up.depth.at(19, 10)));  // coarse 9 and its neighbours 8, 10: none valid
  EXPECT_EQ(up.normal.at(19, 10, 2), 0.0f);
  EXPECT_TRUE(std::isfinite(up.depth.at(10, 10)));  // coarse 5 has 4 as a neighbour
}

PinholeCamera cameraAt(const Eigen::Vector3d& centre, int width = 64, int height = 48) {
  PinholeCamera camera = test::centredCamera(width, height, 60.0);
  camera.t = -camera.R * centre;
  return camera;
}

TEST(PlaneMap, ReprojectionIsExactOnAPlaneAndCoversItsView) {
  const PinholeCamera from = cameraAt({-0.2, 0.0, 0.0}), to = cameraAt({0.2, 0.05, 0.1});
  const PlaneMap source = planeIn(from);
  const PlaneMap out = reprojectPlanes({{from, source.depth, source.normal, ImageViewF()}}, to, 0.5f);
  const PlaneMap truth = planeIn(to);
  int written = 0, seen = 0;
  for (int y = 0; y < to.height; ++y) {
    for (int x = 0; x < to.width; ++x) {
      // Pixels of `to` whose plane point `from` sees.
      const Eigen::Vector3d world = to.R.transpose() * (to.backproject(x, y, truth.depth.at(x, y)) - to.t);
      const bool visible = from.contains(from.project(from.toCamera(world)));
      seen += visible;
      if (std::isnan(out.depth.at(x, y))) continue;
      ++written;
      ASSERT_NEAR(out.depth.at(x, y), truth.depth.at(x, y), 2e-5 * truth.depth.at(x, y)) << x << "," << y;
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(out.normal.at(x, y, c), truth.normal.at(x, y, c), 1e-5);
    }
  }
  // Measured: 2845 pixels written where `from` sees 2797 (the splat reaches
  // one pixel beyond the edge of `from`'s view).
  EXPECT_GE(written, 0.99 * seen) << written << " of " << seen;
  EXPECT_LE(written, seen + 2 * (to.width + to.height));
}

TEST(PlaneMap, ReprojectionKeepsTheNearestPlaneAndOnlyConfidentPixels) {
  const PinholeCamera from = cameraAt({0.0, 0.0, 0.0}), to = cameraAt({0.1, 0.0, 0.0});
  const Eigen::Vector3d facing(0, 0, -1);
  const PlaneMap near_map = planeIn(from, facing, 2.0), far_map = planeIn(from, facing, 4.0);
  ImageF cost(from.width, from.height, 1, 0.2f);
  // The far plane first, then the near one: the near one wins everywhere.
  PlaneMap out = reprojectPlanes({{from, far_map.depth, far_map.normal, cost}, {from, near_map.depth, near_map.normal, cost}},
                                 to, 0.5f);
  EXPECT_NEAR(out.depth.at(32, 24), 2.0f, 1e-5);
  // The near plane's pixels too costly: the far one shows.
  ImageF high(from.width, from.height, 1, 0.9f);
  out = reprojectPlanes({{from, far_map.depth, far_map.normal, cost}, {from, near_map.depth, near_map.normal, high}}, to,
                        0.5f);
  EXPECT_NEAR(out.depth.at(32, 24), 4.0f, 1e-5);
}

TEST(PlaneMap, ReprojectionRefusesMapsOfTheWrongSize) {
  const PinholeCamera from = cameraAt({0.0, 0.0, 0.0}), to = cameraAt({0.1, 0.0, 0.0});
  const ImageF depth(10, 10, 1, 2.0f), normal(10, 10, 3, 0.0f);
  try {
    reprojectPlanes({{from, depth, normal, ImageViewF()}}, to, 0.5f);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("plane map 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("64x48"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
