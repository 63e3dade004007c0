// Bilaterally weighted NCC matching cost (matching_cost.h, paper eq. 15),
// checked against an independent double-precision reference.
#include "amhmvs_mapping/mvs/matching_cost.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <random>
#include <vector>

#include "mvs/backends.h"
#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

constexpr int kWidth = 80, kHeight = 60;

PinholeCamera referenceCamera() {
  PinholeCamera c = test::centredCamera(kWidth, kHeight, 70);
  return c;
}

// Source: other intrinsics and size, rotated a few degrees, off-axis baseline.
PinholeCamera sourceCamera() {
  PinholeCamera c;
  c.fx = 72;
  c.fy = 71;
  c.cx = 41.2;
  c.cy = 30.1;
  c.width = 84;
  c.height = 62;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  const Eigen::Vector3d centre(0.4, 0.05, -0.03);
  c.R = R;
  c.t = -R * centre;
  return c;
}

// Scene: the world plane z = 4 - 0.2 x with a smooth texture plus fixed noise.
double sceneDepthAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  // origin + s dir on z + 0.2 x = 4.
  return (4.0 - origin.z() - 0.2 * origin.x()) / (dir.z() + 0.2 * dir.x());
}

double texture(const Eigen::Vector3d& X) {
  // Periods of 3 to 30 px at 4 m (0.057 m per pixel): texture at every scale.
  return 128 + 30 * std::sin(3.1 * X.x() + 0.7 * X.y()) + 30 * std::sin(23 * X.x() + 17 * X.y()) +
         30 * std::cos(31 * X.y() - 13 * X.x()) + 20 * std::sin(41 * X.x()) * std::cos(37 * X.y());
}

ImageU8 render(const PinholeCamera& cam, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> noise(-2, 2);
  ImageU8 image(cam.width, cam.height);
  const Eigen::Vector3d origin = cam.center();
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const Eigen::Vector3d dir = cam.R.transpose() * cam.backproject(x, y, 1.0);
      const Eigen::Vector3d X = origin + sceneDepthAlong(origin, dir) * dir;
      const double v = texture(X) + noise(rng);
      image.at(x, y) = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  }
  return image;
}

double pixelAt(const ImageU8& image, int x, int y) {
  x = std::clamp(x, 0, image.width - 1);
  y = std::clamp(y, 0, image.height - 1);
  return image.at(x, y);
}

// Own bilinear sample, clamp to edge, as the texture unit filters (not
// mvs::textureBilinear): fractions a, b rounded to 1/256, and each of the
// four weights (1-a)(1-b), a(1-b), (1-a)b, ab rounded half to even to 1/256.
double bilinear(const ImageU8& image, double x, double y) {
  const double qx = std::floor(x * 256.0 + 0.5), qy = std::floor(y * 256.0 + 0.5);
  const double fx = std::floor(qx / 256.0), fy = std::floor(qy / 256.0);
  const double a = (qx - 256.0 * fx) / 256.0, b = (qy - 256.0 * fy) / 256.0;
  auto q = [](double w) { return std::nearbyint(w * 256.0) / 256.0; };  // ties to even
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  return q((1 - a) * (1 - b)) * pixelAt(image, ix, iy) + q(a * (1 - b)) * pixelAt(image, ix + 1, iy) +
         q((1 - a) * b) * pixelAt(image, ix, iy + 1) + q(a * b) * pixelAt(image, ix + 1, iy + 1);
}

struct DPlane {
  Eigen::Vector3d n;
  double d;
};

// Where the reference ray through (u, v) meets the plane, then into the source.
Eigen::Vector3d sourcePoint(const PinholeCamera& ref, const RelativePose& rel, const DPlane& plane,
                            double u, double v) {
  const Eigen::Vector3d ray = ref.backproject(u, v, 1.0);
  const double depth = -plane.d / plane.n.dot(ray);
  return rel.R * (depth * ray) + rel.t;
}

// How far the float cost may be from the double reference at one pixel
// (numerical analysis of matching_cost.h; u = 2^-24, n window samples):
// 1. Source positions: the float path rounds H's entries from float A, b and
//    q, takes a 3-term dot product, steps up to 5 times along the row and
//    divides by hz: about 13 roundings, each at most an ulp of the
//    coordinate when |hz| ~ 1. kPositionUlps = 64 allows 5x for cancellation,
//    so |float - double position| <= 64 u max(|x|, |y|, 1) (< 7e-4 px here,
//    a fifth of the 1/256 px step of the bilinear fractions). A fraction can
//    thus round to a neighbouring 1/256 step only for a sample whose double
//    position lies within that distance of a rounding boundary, and by one
//    step at most: such a sample may change by delta_i, the largest change
//    of the bilinear value over the 8 neighbouring steps.
// 2. To first order the cost moves by |d cost / d s_i| delta_i, with
//    d NCC / d s_i = w_i ((r_i - m_r) / sqrt(v_r v_s) - NCC (s_i - m_s) / v_s).
// 3. Float sums over n terms are off by at most gamma_n = n u / (1 - n u)
//    times the sum of the terms' magnitudes (Higham, Accuracy and Stability,
//    3.1); the one-pass source variance and the covariance therefore carry
//    gamma_n (S2 + 2 |m_s| S1) with S1, S2 the weighted first and second
//    absolute moments about the centre sample, relative to sqrt(v_r v_s) and
//    v_s; 4x covers the weights' own rounding (expf, normalisation).
// The bound is evaluated per pixel; nothing in it depends on the compiler.
constexpr double kUnitRoundoff = 1.0 / (1 << 24);
constexpr double kPositionUlps = 64;

// Largest change of the bilinear sample at p when either fraction rounds to a
// neighbouring 1/256 step, if p lies within `slack` px of a rounding boundary.
double quantisationFlip(const ImageU8& image, const Eigen::Vector2d& p, double slack) {
  auto near_boundary = [&](double c) {
    const double steps = c * 256.0 + 0.5;  // boundaries where this is an integer
    return std::abs(steps - std::round(steps)) <= slack * 256.0;
  };
  if (!near_boundary(p.x()) && !near_boundary(p.y())) return 0.0;
  const double here = bilinear(image, p.x(), p.y());
  double flip = 0;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      flip = std::max(flip, std::abs(bilinear(image, p.x() + dx / 256.0, p.y() + dy / 256.0) - here));
    }
  }
  return flip;
}

// Paper eq. 15 in double: bilateral weights from the reference, kMaxCost for
// textureless windows and for a centre outside or behind the source. Window
// samples outside the reference image are left out. `tolerance` (optional):
// the bound above on |float cost - this cost|.
double referenceCost(const ImageU8& ref_image, const ImageU8& src_image, const PinholeCamera& ref,
                     const PinholeCamera& src, const DPlane& plane, int x, int y,
                     int radius = 5, int step = 2, double sigma_color = 3.0,
                     double sigma_spatial = 30.0, double* tolerance = nullptr) {
  const RelativePose rel = relativePose(ref, src);
  const Eigen::Vector3d centre = sourcePoint(ref, rel, plane, x, y);
  if (!(centre.z() > 0)) return 2.0;
  if (!src.contains(src.project(centre))) return 2.0;
  std::vector<double> w, r, s, flip;
  const double ic = pixelAt(ref_image, x, y);
  for (int dy = -radius; dy <= radius; dy += step) {
    for (int dx = -radius; dx <= radius; dx += step) {
      if (x + dx < 0 || y + dy < 0 || x + dx >= ref_image.width || y + dy >= ref_image.height) {
        continue;
      }
      const double ir = pixelAt(ref_image, x + dx, y + dy);
      w.push_back(std::exp(-std::abs(ir - ic) / (2 * sigma_color * sigma_color) -
                           std::sqrt(dx * dx + dy * dy) / (2 * sigma_spatial * sigma_spatial)));
      r.push_back(ir);
      const Eigen::Vector2d p = src.project(sourcePoint(ref, rel, plane, x + dx, y + dy));
      s.push_back(bilinear(src_image, p.x(), p.y()));
      const double slack = kPositionUlps * kUnitRoundoff * std::max({std::abs(p.x()), std::abs(p.y()), 1.0});
      flip.push_back(quantisationFlip(src_image, p, slack));
    }
  }
  double sw = 0, mr = 0, ms = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    sw += w[i];
    mr += w[i] * r[i];
    ms += w[i] * s[i];
  }
  mr /= sw;
  ms /= sw;
  double vr = 0, vs = 0, cov = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    vr += w[i] * (r[i] - mr) * (r[i] - mr) / sw;
    vs += w[i] * (s[i] - ms) * (s[i] - ms) / sw;
    cov += w[i] * (r[i] - mr) * (s[i] - ms) / sw;
  }
  if (vr < 1e-5 || vs < 1e-5) return 2.0;
  const double ncc = cov / std::sqrt(vr * vs);
  if (tolerance) {
    const double n = static_cast<double>(w.size());
    const double gamma = n * kUnitRoundoff / (1 - n * kUnitRoundoff);
    // The float path centres the source samples on the value at the window
    // centre's source position.
    const Eigen::Vector2d c = src.project(centre);
    const double shift = bilinear(src_image, c.x(), c.y());
    double first_order = 0, s1 = 0, s2 = 0;
    for (size_t i = 0; i < w.size(); ++i) {
      const double wi = w[i] / sw;
      first_order += wi * std::abs((r[i] - mr) / std::sqrt(vr * vs) - ncc * (s[i] - ms) / vs) * flip[i];
      s1 += wi * std::abs(s[i] - shift);
      s2 += wi * (s[i] - shift) * (s[i] - shift);
    }
    const double sums = 4 * gamma * (s2 + 2 * std::abs(ms - shift) * s1);
    *tolerance = first_order + sums / std::sqrt(vr * vs) + sums / vs;
  }
  return std::clamp(1.0 - ncc, 0.0, 2.0);
}

Plane toFloat(const DPlane& p) {
  return {{static_cast<float>(p.n.x()), static_cast<float>(p.n.y()), static_cast<float>(p.n.z())},
          static_cast<float>(p.d)};
}

DPlane toDouble(const Plane& p) { return {Eigen::Vector3d(p.n.x, p.n.y, p.n.z), p.d}; }


class MatchingCost : public ::testing::Test {
 protected:
  void SetUp() override { setUp(referenceCamera(), sourceCamera()); }

  void setUp(const PinholeCamera& ref, const PinholeCamera& src) {
    ref_ = ref;
    src_ = src;
    if (ref_image_.empty()) ref_image_ = render(ref_, 1);
    if (src_image_.empty() || !src_image_.sameSize(src_.width, src_.height)) {
      src_image_ = render(src_, 2);
    }
    rebuild();
  }

  void rebuild() {
    problem_.reference_camera = ref_;
    problem_.reference_image = ref_image_;
    problem_.source_cameras = {src_};
    problem_.source_images = {src_image_};
    problem_.depth_min = 1;
    problem_.depth_max = 10;
    params_ = makePatchMatchParams(PatchMatchOptions(), problem_);
    sampler_ = CpuSampler{};
    sampler_.reference_image = ref_image_;
    padded_source_ = std::make_unique<PaddedImage8>(src_image_);
    sampler_.sources[0] = padded_source_.get();
  }

  // The paper's window, compiled in (what the backends use for the defaults).
  template <class Window = PaperWindow>
  float cost(const Plane& plane, int x, int y) const {
    ReferenceWindow win;
    computeReferenceWindow<Window>(sampler_, params_.cost, x, y, &win);
    return matchingCost<Window>(sampler_, params_.cost, win, params_.sources[0],
                                planeTerm(params_.K, plane), x, y);
  }

  // The true scene plane in the reference frame (reference pose is identity).
  DPlane scenePlane() const {
    const Eigen::Vector3d n = Eigen::Vector3d(-0.2, 0, -1).normalized();
    return {n, 4.0 / Eigen::Vector3d(0.2, 0, 1).norm()};  // z + 0.2 x = 4
  }

  PinholeCamera ref_, src_;
  ImageU8 ref_image_, src_image_;
  DepthProblem problem_;
  PatchMatchParams params_;
  std::unique_ptr<PaddedImage8> padded_source_;
  CpuSampler sampler_;
};

TEST_F(MatchingCost, ParamsAreThePapersWindow) {
  EXPECT_EQ(params_.cost.window_radius, 5);
  EXPECT_EQ(params_.cost.window_step, 2);
  EXPECT_FLOAT_EQ(params_.cost.sigma_color, 3.0f);
  EXPECT_FLOAT_EQ(params_.cost.sigma_spatial, 30.0f);
  EXPECT_TRUE(isPaperWindow(params_.cost));
  ReferenceWindow win;
  computeReferenceWindow<PaperWindow>(sampler_, params_.cost, 40, 30, &win);
  EXPECT_EQ(win.count, 36);  // 6 x 6 samples
  double sum = 0;
  for (int i = 0; i < win.count; ++i) sum += win.sample[i].weight;
  EXPECT_NEAR(sum, 1.0, 1e-6);
}

TEST_F(MatchingCost, AgreesWithDoubleReferenceOnRandomPlanes) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> px(0, kWidth - 1), py(0, kHeight - 1);
  std::uniform_real_distribution<double> uni(0, 1);
  const DPlane truth = scenePlane();
  int checked = 0, low = 0, high = 0, clamped_edges = 0, flipped = 0;
  double max_error = 0, max_tolerance = 0;
  for (int trial = 0; trial < 2000 && checked < 600; ++trial) {
    const int x = px(rng), y = py(rng);
    const Eigen::Vector3d ray = ref_.backproject(x, y, 1.0);
    // Half near the true plane (low costs), half random (costs near 1 and up).
    Eigen::Vector3d n;
    double depth;
    if (trial % 2 == 0) {
      n = (truth.n + 0.05 * Eigen::Vector3d(uni(rng) - 0.5, uni(rng) - 0.5, uni(rng) - 0.5))
              .normalized();
      depth = -truth.d / truth.n.dot(ray) * (1 + 0.01 * (uni(rng) - 0.5));
    } else {
      // Random normal within ~60 degrees of facing the camera.
      n = (-ray.normalized() + 1.2 * Eigen::Vector3d(uni(rng) - 0.5, uni(rng) - 0.5,
                                                   uni(rng) - 0.5))
              .normalized();
      if (n.dot(ray) >= -0.5 * ray.norm()) continue;
      depth = 2.5 + 4.0 * uni(rng);
    }
    // Through the float plane, so both sides score the same hypothesis.
    const Plane plane = toFloat({n, -n.dot(depth * ray)});
    const DPlane dplane = toDouble(plane);
    const RelativePose rel = relativePose(ref_, src_);
    const Eigen::Vector3d centre = sourcePoint(ref_, rel, dplane, x, y);
    const Eigen::Vector2d c = src_.project(centre);
    // Keep the centre a pixel away from the image border, where float and
    // double could disagree on "inside".
    if (!(centre.z() > 0 && c.x() > 0.5 && c.y() > 0.5 && c.x() < src_.width - 1.5 &&
          c.y() < src_.height - 1.5)) {
      continue;
    }
    double tolerance = 0;
    const double want =
        referenceCost(ref_image_, src_image_, ref_, src_, dplane, x, y, 5, 2, 3.0, 30.0, &tolerance);
    const float got = cost(plane, x, y);
    EXPECT_NEAR(got, want, tolerance) << "pixel (" << x << "," << y << ") trial " << trial;
    max_error = std::max(max_error, std::abs(got - want));
    max_tolerance = std::max(max_tolerance, tolerance);
    flipped += tolerance > 1e-4;
    ++checked;
    low += want < 0.3;
    high += want > 0.9;
    clamped_edges += x < 5 || y < 5 || x >= kWidth - 5 || y >= kHeight - 5;
  }
  EXPECT_GE(checked, 500);
  EXPECT_GE(low, 50);   // the near-true planes match well
  EXPECT_GE(high, 50);  // the random ones do not
  EXPECT_GE(clamped_edges, 20);  // windows clamped at the reference border
  // The bound stays useful: no pixel's reaches a hundredth of a cost unit
  // (the near-true and random planes differ by more than 0.6).
  EXPECT_LT(max_tolerance, 0.01);
  RecordProperty("max_error", std::to_string(max_error));
  RecordProperty("max_tolerance", std::to_string(max_tolerance));
  std::cout << "[ bound    ] max |float - double| " << max_error << ", max bound " << max_tolerance
            << ", " << flipped << " of " << checked << " pixels with a sample near a 1/256 boundary\n";
}

TEST_F(MatchingCost, RuntimeWindowAgreesWithReferenceForOtherShapesAndSigmas) {
  // The run-time window path serves every non-default option value; check it
  // on other shapes and on the public code's sigma_x = 5 against the same
  // double reference.
  struct Shape {
    int radius, step;
    float sigma_color, sigma_spatial;
  };
  const Shape shapes[] = {{5, 2, 3, 30}, {3, 1, 3, 30}, {7, 2, 3, 30}, {2, 1, 10, 5}, {5, 2, 3, 5}};
  const DPlane truth = scenePlane();
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> px(8, kWidth - 9), py(8, kHeight - 9);
  std::uniform_real_distribution<double> uni(0, 1);
  for (const Shape& shape : shapes) {
    params_.cost = {shape.radius, shape.step, shape.sigma_color, shape.sigma_spatial};
    int checked = 0;
    for (int trial = 0; trial < 100; ++trial) {
      const int x = px(rng), y = py(rng);
      const Eigen::Vector3d ray = ref_.backproject(x, y, 1.0);
      const double depth = -truth.d / truth.n.dot(ray) * (0.9 + 0.2 * uni(rng));
      const Plane plane = toFloat({truth.n, -truth.n.dot(depth * ray)});
      double tolerance = 0;
      const double want = referenceCost(ref_image_, src_image_, ref_, src_, toDouble(plane), x, y,
                                        shape.radius, shape.step, shape.sigma_color,
                                        shape.sigma_spatial, &tolerance);
      const float got = cost<RuntimeWindow>(plane, x, y);
      EXPECT_NEAR(got, want, tolerance) << "radius " << shape.radius << " step " << shape.step
                                   << " pixel (" << x << "," << y << ")";
      if (isPaperWindow(params_.cost)) {
        // Compiled-in and run-time shapes run the same arithmetic.
        EXPECT_NEAR(cost<PaperWindow>(plane, x, y), got, 1e-6);
      }
      checked += want < 2.0;
    }
    EXPECT_GE(checked, 90) << "radius " << shape.radius;
  }
}

TEST_F(MatchingCost, TruePlaneScoresLowerThanWrongDepth) {
  // Ground truth sanity of the rendered pair: the scene plane matches well
  // and a 20 % wrong depth does not.
  const DPlane truth = scenePlane();
  double sum_true = 0, sum_wrong = 0;
  int n = 0;
  for (int y = 8; y < kHeight - 8; y += 7) {
    for (int x = 8; x < kWidth - 8; x += 7) {
      const Eigen::Vector3d ray = ref_.backproject(x, y, 1.0);
      const double depth = -truth.d / truth.n.dot(ray);
      sum_true += cost(toFloat(truth), x, y);
      sum_wrong += cost(toFloat({truth.n, -truth.n.dot(1.2 * depth * ray)}), x, y);
      ++n;
    }
  }
  EXPECT_LT(sum_true / n, 0.2);
  EXPECT_GT(sum_wrong / n, 0.5);
}

TEST_F(MatchingCost, HomographyMatchesPlanePointProjection) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(0, 1);
  const RelativePose rel = relativePose(ref_, src_);
  const SourceGeometry& g = params_.sources[0];
  EXPECT_EQ(g.width, 84.0f);
  EXPECT_EQ(g.height, 62.0f);
  for (int trial = 0; trial < 500; ++trial) {
    const double x = uni(rng) * (kWidth - 1), y = uni(rng) * (kHeight - 1);
    const Eigen::Vector3d ray = ref_.backproject(x, y, 1.0);
    Eigen::Vector3d n = (-ray.normalized() +
                         Eigen::Vector3d(uni(rng) - 0.5, uni(rng) - 0.5, uni(rng) - 0.5))
                            .normalized();
    if (n.dot(ray) >= -0.3 * ray.norm()) n = -ray.normalized();
    const double depth = 1.0 + 9.0 * uni(rng);
    const Plane plane = toFloat({n, -n.dot(depth * ray)});
    const Vec3 q = planeTerm(params_.K, plane);
    // H = A - b q^T, applied in double.
    Eigen::Matrix3d H;
    const double bq[3] = {g.b.x, g.b.y, g.b.z};
    const double qq[3] = {q.x, q.y, q.z};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) H(r, c) = g.A.m[3 * r + c] - bq[r] * qq[c];
    }
    const Eigen::Vector3d h = H * Eigen::Vector3d(x, y, 1.0);
    const Eigen::Vector3d X = sourcePoint(ref_, rel, toDouble(plane), x, y);
    const Eigen::Vector2d want = src_.project(X);
    ASSERT_GT(h.z(), 0) << "trial " << trial;  // same side as the source camera
    EXPECT_NEAR(h.x() / h.z(), want.x(), 1e-3) << "trial " << trial;
    EXPECT_NEAR(h.y() / h.z(), want.y(), 1e-3) << "trial " << trial;
    // H p is the source point divided by the reference depth.
    EXPECT_NEAR(h.z(), X.z() / depth, 1e-4 * X.z() / depth);
  }
}

TEST_F(MatchingCost, CentreOutsideSourceIsMaxCost) {
  // Source 0.1 m to the right, no rotation: a fronto-parallel plane at 0.1 m
  // shifts the window 70 px left, out of the image.
  PinholeCamera src = referenceCamera();
  src.t = Eigen::Vector3d(-0.1, 0, 0);
  src_image_ = ref_image_;
  setUp(referenceCamera(), src);
  const Vec3 ray = pixelRay(params_.K, 40, 30);
  const Plane near_plane = planeFromDepthNormal({0, 0, -1}, 1.5f, ray);  // shift 4.7 px
  EXPECT_LT(cost(near_plane, 40, 30), 2.0f);
  const Plane too_near = planeFromDepthNormal({0, 0, -1}, 0.1f, ray);  // shift 70 px
  EXPECT_EQ(cost(too_near, 40, 30), kMaxCost);
  // At the left edge a shift of 1 px is already outside (u = -1 < -0.5).
  const Plane one_px = planeFromDepthNormal({0, 0, -1}, 7.0f, pixelRay(params_.K, 0, 30));
  EXPECT_EQ(cost(one_px, 0, 30), kMaxCost);
  EXPECT_LT(cost(one_px, 1, 30), 2.0f);  // u = 0: inside
}

TEST_F(MatchingCost, PointBehindSourceCameraIsMaxCost) {
  // Source at x = 0.1 m looking backwards (180 degrees about y): every point
  // in front of the reference is behind it. The naive projection of the
  // centre still lands inside the source image, so only the depth test can
  // reject it.
  PinholeCamera src = referenceCamera();
  src.R = Eigen::Vector3d(-1, 1, -1).asDiagonal();
  src.t = -src.R * Eigen::Vector3d(0.1, 0, 0);
  src_image_ = ref_image_;
  setUp(referenceCamera(), src);
  const Vec3 ray = pixelRay(params_.K, 40, 30);
  const Plane plane = planeFromDepthNormal({0, 0, -1}, 3.0f, ray);
  const Eigen::Vector3d X = src.toCamera(Eigen::Vector3d(0.5 / 70 * 3, 0.5 / 70 * 3, 3.0));
  ASSERT_LT(X.z(), 0);
  ASSERT_TRUE(src.contains(src.project(X)));  // the trap
  EXPECT_EQ(cost(plane, 40, 30), kMaxCost);
}

TEST_F(MatchingCost, TexturelessWindowsAreMaxCost) {
  // Constant reference window: no texture, whatever the source.
  ref_image_ = ImageU8(kWidth, kHeight, 1, 90);
  rebuild();
  const Plane plane = toFloat(scenePlane());
  EXPECT_EQ(cost(plane, 40, 30), kMaxCost);
  ReferenceWindow win;
  computeReferenceWindow<PaperWindow>(sampler_, params_.cost, 40, 30, &win);
  EXPECT_FALSE(win.textured);
  EXPECT_EQ(win.variance, 0.0f);

  // Textured reference, constant source.
  ref_image_ = render(ref_, 1);
  src_image_ = ImageU8(src_.width, src_.height, 1, 200);
  rebuild();
  computeReferenceWindow<PaperWindow>(sampler_, params_.cost, 40, 30, &win);
  EXPECT_TRUE(win.textured);
  EXPECT_EQ(cost(plane, 40, 30), kMaxCost);
}

TEST_F(MatchingCost, IdenticalShiftedPatchCostsZero) {
  // Fronto-parallel plane at 3.5 m, source translated 0.1 m along x: the
  // homography is a shift of exactly 70 * 0.1 / 3.5 = 2 px. The source image
  // is the reference shifted by the same 2 px, so every window matches.
  PinholeCamera src = referenceCamera();
  src.t = Eigen::Vector3d(-0.1, 0, 0);
  ImageU8 shifted(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      shifted.at(x, y) = ref_image_.at(std::min(x + 2, kWidth - 1), y);
    }
  }
  src_image_ = shifted;
  setUp(referenceCamera(), src);
  int scored = 0;
  float worst = 0;
  for (int y = 5; y < kHeight - 5; ++y) {
    for (int x = 7; x < kWidth - 5; ++x) {
      const Plane plane = planeFromDepthNormal({0, 0, -1}, 3.5f, pixelRay(params_.K, x, y));
      const float c = cost(plane, x, y);
      worst = std::max(worst, c);
      ++scored;
    }
  }
  EXPECT_EQ(scored, (kHeight - 10) * (kWidth - 12));
  EXPECT_LT(worst, 1e-4f);
  // A 2 px wrong shift (depth 70 * 0.1 / 4 = 1.75 m) is clearly worse.
  const Plane wrong = planeFromDepthNormal({0, 0, -1}, 1.75f, pixelRay(params_.K, 40, 30));
  EXPECT_GT(cost(wrong, 40, 30), 0.1f);
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
