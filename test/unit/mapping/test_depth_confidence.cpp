// The per-pixel confidence (depth_confidence.h, confidence_calibration.h):
// the agreement counts equal a brute-force reference on small maps, a case of
// known agreement gets the table's value, the published depth is NaN exactly
// where the confidence is below the level, the fit is the table's formula,
// and bad input is refused with a message.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <limits>
#include <random>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Rendered views of the slanted-planes scene with their normals and a cost
// map; views borrow `images` (a deque: they stay where they are).
struct Views {
  std::deque<DepthMapImages> images;
  std::vector<FusionView> views;
};

Views renderViews(int count, int width, int height) {
  Views v;
  const SyntheticWorld world = makeSlantedPlanesWorld(3);
  const std::vector<PinholeCamera> cameras = makeSidewaysCameras(count, width, height);
  for (int i = 0; i < count; ++i) {
    RenderedView r = renderView(world, cameras[i], 1);
    DepthMapImages& images = v.images.emplace_back();
    images.depth = std::move(r.depth);
    images.normal = std::move(r.normal);
    images.cost = ImageF(width, height, 1, 0.1f);
    v.views.push_back(images.borrow(i, r.camera));
  }
  return v;
}

// The brute-force agreement of reference pixel (x, y) with one view: the
// definition of fusion.h written out with Eigen.
enum class Verdict { kNotSeen, kDisagrees, kAgrees };
Verdict bruteForce(const FusionView& ref, const FusionView& src, const FusionOptions& checks, int x, int y) {
  const double d = ref.depth.at(x, y);
  const Eigen::Vector3d X = ref.camera.R.transpose() *
                            (Eigen::Vector3d((x - ref.camera.cx) / ref.camera.fx * d,
                                             (y - ref.camera.cy) / ref.camera.fy * d, d) -
                             ref.camera.t);
  const Eigen::Vector3d Xs = src.camera.R * X + src.camera.t;
  if (!(Xs.z() > 0)) return Verdict::kNotSeen;
  const double u = src.camera.fx * Xs.x() / Xs.z() + src.camera.cx;
  const double v = src.camera.fy * Xs.y() / Xs.z() + src.camera.cy;
  if (!(u >= -0.5 && v >= -0.5 && u < src.camera.width - 0.5 && v < src.camera.height - 0.5)) return Verdict::kNotSeen;
  const int sx = static_cast<int>(std::floor(u + 0.5)), sy = static_cast<int>(std::floor(v + 0.5));
  const double ds = src.depth.at(sx, sy);
  if (!(std::isfinite(ds) && ds > 0)) return Verdict::kDisagrees;
  const Eigen::Vector3d n_ref(ref.normal.at(x, y, 0), ref.normal.at(x, y, 1), ref.normal.at(x, y, 2));
  const Eigen::Vector3d n_src(src.normal.at(sx, sy, 0), src.normal.at(sx, sy, 1), src.normal.at(sx, sy, 2));
  const double cosine = (ref.camera.R.transpose() * n_ref.normalized()).dot(src.camera.R.transpose() * n_src.normalized());
  if (std::isfinite(checks.max_normal_angle_deg) && !(cosine > std::cos(checks.max_normal_angle_deg * M_PI / 180)))
    return Verdict::kDisagrees;
  const Eigen::Vector3d Xj = src.camera.R.transpose() *
                             (Eigen::Vector3d((sx - src.camera.cx) / src.camera.fx * ds,
                                              (sy - src.camera.cy) / src.camera.fy * ds, ds) -
                              src.camera.t);
  const Eigen::Vector3d back = ref.camera.R * Xj + ref.camera.t;
  if (!(back.z() > 0) || !(std::abs(back.z() - d) / d < checks.max_relative_depth_difference)) return Verdict::kDisagrees;
  const double du = ref.camera.fx * back.x() / back.z() + ref.camera.cx - x;
  const double dv = ref.camera.fy * back.y() / back.z() + ref.camera.cy - y;
  return std::hypot(du, dv) < checks.max_reprojection_error ? Verdict::kAgrees : Verdict::kDisagrees;
}

TEST(DepthConfidence, AgreementCountsEqualABruteForceReference) {
  Views v = renderViews(4, 48, 36);
  // Views 1 and 2 wrong in blocks (10 % and 2 % too far) and view 3 noisy
  // by up to 6 %: every verdict occurs, at many distances from the thresholds.
  for (int y = 5; y < 30; ++y)
    for (int x = 5; x < 25; ++x) v.images[1].depth.at(x, y) *= 1.10f;
  for (int y = 10; y < 36; ++y)
    for (int x = 20; x < 48; ++x) v.images[2].depth.at(x, y) *= 1.02f;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.06f, 0.06f);
  for (float& d : v.images[3].depth.data) d *= 1 + noise(rng);
  v.images[3].depth.at(7, 7) = kNaN;
  for (int y = 0; y < 18; ++y)  // normals the 10 degree check refuses
    for (int x = 24; x < 48; ++x) v.images[3].normal.at(x, y, 0) += 1.0f;
  v.images[0].depth.at(3, 4) = kNaN;
  const FusionView& ref = v.views[0];
  const std::vector<FusionView> others(v.views.begin() + 1, v.views.end());
  FusionOptions with_normals = defaultConfidenceCalibration().checks;
  with_normals.max_normal_angle_deg = 10;
  std::vector<int> agreeing_totals;
  for (const FusionOptions& checks : {defaultConfidenceCalibration().checks, with_normals}) {
    const AgreementCounts counts = countAgreement(ref, others, checks);
    int agreeing_total = 0, disagreeing_total = 0;
    for (int y = 0; y < 36; ++y) {
      for (int x = 0; x < 48; ++x) {
        int seen = 0, agreeing = 0;
        if (std::isfinite(ref.depth.at(x, y))) {
          for (const FusionView& other : others) {
            const Verdict verdict = bruteForce(ref, other, checks, x, y);
            seen += verdict != Verdict::kNotSeen;
            agreeing += verdict == Verdict::kAgrees;
          }
        }
        ASSERT_EQ(counts.seen.at(x, y), seen) << x << " " << y;
        ASSERT_EQ(counts.agreeing.at(x, y), agreeing) << x << " " << y;
        agreeing_total += agreeing;
        disagreeing_total += seen - agreeing;
      }
    }
    std::cout << "[ agreement ] " << agreeing_total << " agreeing, " << disagreeing_total << " disagreeing\n";
    EXPECT_GT(agreeing_total, 500);
    EXPECT_GT(disagreeing_total, 500);
    agreeing_totals.push_back(agreeing_total);
  }
  EXPECT_LT(agreeing_totals[1], agreeing_totals[0]);  // the normal check refused some
}

// Three parallel cameras 0.2 m apart facing a plane at 4 m (f = 50 px): the
// reference, one view that sees the plane where it is and one that sees it
// 25 % too far.
class KnownAgreement : public ::testing::Test {
 protected:
  FusionView planeView(int id, double x, float depth, float cost) {
    DepthMapImages& images = owned_.emplace_back();
    images.depth = ImageF(64, 48, 1, depth);
    images.normal = ImageF(64, 48, 3, 0.0f);
    for (size_t i = 0; i < images.depth.pixelCount(); ++i) images.normal.data[3 * i + 2] = -1;
    images.cost = ImageF(64, 48, 1, cost);
    PinholeCamera camera = test::centredCamera(64, 48, 50);
    camera.t = Eigen::Vector3d(-x, 0, 0);
    return images.borrow(id, camera);
  }
  std::deque<DepthMapImages> owned_;
};

TEST_F(KnownAgreement, ConfidenceIsTheTablesValueForTheEvidence) {
  const ConfidenceCalibration& table = defaultConfidenceCalibration();
  for (const float cost : {0.05f, 0.3f, 0.7f, 1.5f}) {
    const FusionView ref = planeView(0, 0.0, 4.0f, cost);
    const std::vector<FusionView> others = {planeView(1, 0.2, 4.0f, 0.1f), planeView(2, -0.2, 5.0f, 0.1f)};
    ConfidenceOptions options;
    options.min_probability = 0;
    const PublishedDepth published = publishDepth(ref, others, options);
    // The middle column sees both views (the plane is 2.5 px of parallax away).
    const float expected = table.probability[table.cell(2, 1, table.costBin(cost))];
    EXPECT_EQ(published.counts.seen.at(32, 24), 2);
    EXPECT_EQ(published.counts.agreeing.at(32, 24), 1);
    EXPECT_EQ(published.confidence.at(32, 24), expected) << cost;
    // Both agree: the (2, 2) cell; no other view: the (0, 0) cell.
    const PublishedDepth both = publishDepth(ref, {planeView(1, 0.2, 4.0f, 0.1f), planeView(2, -0.2, 4.0f, 0.1f)}, options);
    EXPECT_EQ(both.confidence.at(32, 24), table.probability[table.cell(2, 2, table.costBin(cost))]);
    const PublishedDepth alone = publishDepth(ref, {}, options);
    EXPECT_EQ(alone.confidence.at(32, 24), table.probability[table.cell(0, 0, table.costBin(cost))]);
  }
}

TEST(DepthConfidence, PublishedDepthIsNaNExactlyWhereTheConfidenceIsBelowTheLevel) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  ImageF depth(40, 30), confidence(40, 30);
  for (size_t i = 0; i < depth.data.size(); ++i) {
    depth.data[i] = i % 17 == 0 ? kNaN : 1 + 3 * uniform(rng);
    confidence.data[i] = i % 23 == 0 ? 0.5f : uniform(rng);  // some exactly at the level
  }
  for (const float level : {0.0f, 0.5f, 1.0f}) {
    const ImageF masked = maskDepth(depth, confidence, level);
    for (size_t i = 0; i < depth.data.size(); ++i) {
      if (confidence.data[i] < level) {
        EXPECT_TRUE(std::isnan(masked.data[i])) << i;
      } else if (std::isnan(depth.data[i])) {
        EXPECT_TRUE(std::isnan(masked.data[i])) << i;
      } else {
        EXPECT_EQ(masked.data[i], depth.data[i]) << i;
      }
    }
  }
  const ImageF small(4, 3);
  EXPECT_THROW(maskDepth(depth, small, 0.5f), InputError);
}

TEST(DepthConfidence, FitIsLaplaceSmoothedShareWithinPerCell) {
  ConfidenceFit fit(defaultConfidenceCalibration());
  const ConfidenceCalibration& shape = fit.shape();
  for (int i = 0; i < 10; ++i) fit.add(3, 2, 0.05f, i < 7 ? 0.01 : 0.2);  // 7 of 10 within 5 %
  fit.add(9, 9, 0.05f, 0.0);  // counts beyond max_views fall into the last cell
  const ConfidenceCalibration table = fit.table();
  EXPECT_FLOAT_EQ(table.probability[shape.cell(3, 2, 0)], 8.0f / 12.0f);
  EXPECT_FLOAT_EQ(table.probability[shape.cell(shape.max_views, shape.max_views, 0)], 2.0f / 3.0f);
  EXPECT_FLOAT_EQ(table.probability[shape.cell(1, 0, 0)], 0.5f);  // no sample
  EXPECT_EQ(table.lookup(3, 2, 0.05f), table.probability[shape.cell(3, 2, 0)]);
  EXPECT_TRUE(table.validate().empty());
  EXPECT_NE(calibrationSource(fit).find("seen 3, agreeing 2: 10"), std::string::npos) << calibrationSource(fit);
}

TEST(DepthConfidence, CommittedTableIsValidAndBadInputIsRefused) {
  const ConfidenceCalibration& table = defaultConfidenceCalibration();
  EXPECT_TRUE(table.validate().empty()) << table.validate();
  EXPECT_EQ(table.probability.size(), table.cellCount());
  ConfidenceCalibration broken = table;
  broken.probability.pop_back();
  EXPECT_NE(broken.validate().find("cells"), std::string::npos);
  ConfidenceOptions options;
  options.min_probability = 1.5f;
  EXPECT_NE(options.validate().find("min_probability must be in [0, 1] (got 1.5)"), std::string::npos);
  Views v = renderViews(2, 32, 24);
  v.images[1].normal = ImageF(16, 12, 3);
  v.views[1] = v.images[1].borrow(1, v.views[1].camera);
  try {
    countAgreement(v.views[0], {v.views[1]}, table.checks);
    FAIL() << "a normal map of the wrong size was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("view 1: normal map is 16x12"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amhmvs
