// Multi-hypothesis joint view selection (view_selection.h, paper eqs. 9-14)
// against cost matrices worked out by hand with the paper's parameters.
#include "amhmvs_mapping/mvs/view_selection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "mvs/backends.h"
#include "test_helpers.h"

namespace amhmvs {
namespace mvs {
namespace {

constexpr int kStride = 32;  // any row stride >= the number of views

// The paper's parameters as the estimator builds them from the default options.
SelectionParams paperParams() {
  DepthProblem problem;
  PinholeCamera cam = test::centredCamera(10, 10, 10);
  problem.reference_camera = cam;
  const ImageU8 black(10, 10);
  problem.reference_image = black;
  cam.t = Eigen::Vector3d(-0.1, 0, 0);
  problem.source_cameras = {cam};
  problem.source_images = {black};
  problem.depth_min = 1;
  problem.depth_max = 10;
  return makePatchMatchParams(PatchMatchOptions(), problem).selection;
}

// Eq. 10 with beta = 0.3, written out: exp(-m^2 / 0.18).
double C(double m) { return std::exp(-m * m / (2 * 0.3 * 0.3)); }

// Cost matrix given per view (columns, 8 hypotheses each), stored row-major
// with the kernel's stride.
struct Matrix {
  int rows = 0, views = 0;
  std::vector<float> data;

  explicit Matrix(const std::vector<std::vector<double>>& columns)
      : rows(static_cast<int>(columns[0].size())),
        views(static_cast<int>(columns.size())),
        data(static_cast<size_t>(kNumRegions) * kStride, -7.0f) {  // poison unused
    for (int j = 0; j < views; ++j) {
      for (int i = 0; i < rows; ++i) data[i * kStride + j] = static_cast<float>(columns[j][i]);
    }
  }
  const float* row(int i) const { return &data[i * kStride]; }
  double at(int i, int j) const { return data[i * kStride + j]; }
};

ViewWeights select(const Matrix& m, int iteration, uint32_t previous_selected = 0,
                   int previous_best = kNoView) {
  ViewWeights w;
  for (float& v : w.weight) v = -1.0f;  // must be overwritten for every view
  jointViewSelection(paperParams(), m.data.data(), m.rows, kStride, m.views, iteration,
                     previous_selected, previous_best, &w);
  return w;
}

double meanOf(const std::vector<double>& column) {
  double s = 0;
  for (double m : column) s += C(m);
  return s / column.size();
}

TEST(ViewSelection, ParamsAreThePapers) {
  const SelectionParams p = paperParams();
  EXPECT_FLOAT_EQ(p.tau_mc_init, 0.8f);
  EXPECT_FLOAT_EQ(p.tau_alpha, 90.0f);
  EXPECT_FLOAT_EQ(p.tau_up, 1.2f);
  EXPECT_FLOAT_EQ(p.beta, 0.3f);
  EXPECT_EQ(p.n1, 2);
  EXPECT_EQ(p.n2, 3);
  EXPECT_EQ(p.top_k, 4);
  EXPECT_FLOAT_EQ(p.best_view_boost, 2.0f);
  EXPECT_FLOAT_EQ(p.previous_selection_weight, 0.2f);
  EXPECT_EQ(p.heuristic_k, 3);
}

TEST(ViewSelection, ThresholdFollowsEq9) {
  const SelectionParams p = paperParams();
  // 0.8 exp(-t^2 / 90) for t = 0..5.
  const double expected[6] = {0.8, 0.791160311, 0.765222991, 0.723869934, 0.669702745, 0.605972103};
  for (int t = 0; t < 6; ++t) {
    EXPECT_NEAR(goodCostThreshold(p, t), expected[t], 1e-6) << "t = " << t;
    EXPECT_NEAR(goodCostThreshold(p, t), 0.8 * std::exp(-t * t / 90.0), 1e-6) << "t = " << t;
  }
  EXPECT_NEAR(confidence(p, 0.3f), std::exp(-0.5), 1e-6);  // m = beta: exp(-1/2)
  EXPECT_NEAR(confidence(p, 0.0f), 1.0, 1e-7);
}

// Views 0, 1, 4 good; 2 bad (too few good costs at t = 3); 3 bad (too many
// bad costs). At t = 3, tau_mc = 0.8 exp(-9/90) = 0.72387.
const std::vector<std::vector<double>> kThreeGood = {
    {0.10, 0.20, 0.30, 0.50, 0.90, 1.00, 1.30, 1.50},  // 4 below, 2 above: good
    {0.05, 0.40, 0.72, 1.25, 1.30, 0.90, 0.80, 0.73},  // 3 below (0.72 < 0.7239), 2 above: good
    {0.10, 0.20, 0.75, 0.90, 1.00, 1.10, 1.00, 0.90},  // 2 below: not more than n1 = 2
    {0.10, 0.20, 0.30, 0.40, 1.21, 1.50, 2.00, 0.50},  // 3 above 1.2: not fewer than n2 = 3
    {0.00, 0.10, 0.15, 0.60, 0.60, 0.70, 1.00, 1.10},  // 6 below, 0 above: good
};

TEST(ViewSelection, ThreeGoodViewsWeighByMeanConfidence) {
  const Matrix m(kThreeGood);
  const ViewWeights w = select(m, 3);
  // psi (eq. 11), by hand:
  const double psi0 = (C(0.10) + C(0.20) + C(0.30) + C(0.50) + C(0.90) + C(1.00) + C(1.30) +
                       C(1.50)) / 8;  // = 0.327205
  const double psi1 = (C(0.05) + C(0.40) + C(0.72) + C(1.25) + C(1.30) + C(0.90) + C(0.80) +
                       C(0.73)) / 8;  // = 0.193147
  const double psi4 = (C(0.00) + C(0.10) + C(0.15) + C(0.60) + C(0.60) + C(0.70) + C(1.00) +
                       C(1.10)) / 8;  // = 0.396241
  EXPECT_NEAR(psi0, 0.3272053, 1e-6);
  EXPECT_NEAR(psi1, 0.1931465, 1e-6);
  EXPECT_NEAR(psi4, 0.3962407, 1e-6);
  EXPECT_FALSE(w.heuristic);
  EXPECT_NEAR(w.weight[0], psi0, 1e-6);
  EXPECT_NEAR(w.weight[1], psi1, 1e-6);
  EXPECT_EQ(w.weight[2], 0.0f);
  EXPECT_EQ(w.weight[3], 0.0f);
  EXPECT_NEAR(w.weight[4], psi4, 1e-6);
  EXPECT_EQ(w.selected, (1u << 0) | (1u << 1) | (1u << 4));
  EXPECT_EQ(w.best_view, 4);  // psi4 = 0.396241 > psi0 = 0.327205

  // Eq. 14 per hypothesis.
  for (int i = 0; i < m.rows; ++i) {
    const double want = (psi0 * m.at(i, 0) + psi1 * m.at(i, 1) + psi4 * m.at(i, 4)) /
                        (psi0 + psi1 + psi4);
    EXPECT_NEAR(aggregateCost(paperParams(), w, m.row(i), m.views), want, 1e-6) << "row " << i;
  }
}

TEST(ViewSelection, GoodViewRuleDependsOnIteration) {
  // At t = 0 the threshold is 0.8, so view 2's 0.75 counts: 3 good costs.
  const Matrix m(kThreeGood);
  const ViewWeights w0 = select(m, 0);
  EXPECT_EQ(w0.selected, (1u << 0) | (1u << 1) | (1u << 2) | (1u << 4));
  EXPECT_NEAR(w0.weight[2], meanOf(kThreeGood[2]), 1e-6);  // 0.227723
  EXPECT_EQ(w0.weight[3], 0.0f);  // bad at every t
  // At t = 4 (tau = 0.6697) view 1 keeps only 0.05 and 0.40: not good.
  const ViewWeights w4 = select(m, 4);
  EXPECT_EQ(w4.selected, (1u << 0) | (1u << 4));
  EXPECT_EQ(w4.weight[1], 0.0f);
}

// Six good views whose importance falls in the order 5, 1, 3, 0, 4, 2.
std::vector<std::vector<double>> sixGood() {
  const double base[6] = {0.30, 0.10, 0.50, 0.20, 0.40, 0.00};
  std::vector<std::vector<double>> columns;
  for (double c : base) columns.push_back({c, c, c, c + 0.1, c + 0.2, c + 0.3, 0.9, 1.0});
  return columns;
}

TEST(ViewSelection, TopKKeepsTheFourMostImportant) {
  const std::vector<std::vector<double>> columns = sixGood();
  const Matrix m(columns);
  // View 2 was selected last time but is cut now: a view of S_t outside the
  // top k weighs 0 (the 0.2 is only for views not in S_t).
  const ViewWeights w = select(m, 0, 1u << 2);
  double psi[6];
  for (int j = 0; j < 6; ++j) psi[j] = meanOf(columns[j]);
  ASSERT_GT(psi[5], psi[1]);
  ASSERT_GT(psi[1], psi[3]);
  ASSERT_GT(psi[3], psi[0]);
  ASSERT_GT(psi[0], psi[4]);
  ASSERT_GT(psi[4], psi[2]);
  EXPECT_EQ(w.selected, (1u << 5) | (1u << 1) | (1u << 3) | (1u << 0));
  for (int j : {0, 1, 3, 5}) EXPECT_NEAR(w.weight[j], psi[j], 1e-6) << "view " << j;
  EXPECT_EQ(w.weight[4], 0.0f);
  EXPECT_EQ(w.weight[2], 0.0f);
  EXPECT_EQ(w.best_view, 5);
  for (int i = 0; i < m.rows; ++i) {
    double num = 0, den = 0;
    for (int j : {0, 1, 3, 5}) {
      num += psi[j] * m.at(i, j);
      den += psi[j];
    }
    EXPECT_NEAR(aggregateCost(paperParams(), w, m.row(i), m.views), num / den, 1e-6);
  }
}

TEST(ViewSelection, PreviousBestViewCountsTwice) {
  const std::vector<std::vector<double>> columns = sixGood();
  const Matrix m(columns);
  double psi[6];
  for (int j = 0; j < 6; ++j) psi[j] = meanOf(columns[j]);

  // View 4 is 5th; doubled (2 psi4 > psi0) it enters the top 4 and pushes out view 0.
  ASSERT_GT(2 * psi[4], psi[0]);
  const ViewWeights w4 = select(m, 0, 0, 4);
  EXPECT_EQ(w4.selected, (1u << 5) | (1u << 1) | (1u << 3) | (1u << 4));
  EXPECT_NEAR(w4.weight[4], 2 * psi[4], 1e-6);
  EXPECT_EQ(w4.weight[0], 0.0f);
  EXPECT_EQ(w4.best_view, 5);

  // View 2 is last; doubled it is still 5th or below: ranking unchanged.
  ASSERT_LT(2 * psi[2], psi[0]);
  const ViewWeights w2 = select(m, 0, 0, 2);
  EXPECT_EQ(w2.selected, (1u << 5) | (1u << 1) | (1u << 3) | (1u << 0));
  EXPECT_EQ(w2.weight[2], 0.0f);

  // View 1 is doubled above view 5 (2 psi1 > psi5), but v_t is the argmax of
  // the unmodified importance: still view 5.
  ASSERT_GT(2 * psi[1], psi[5]);
  const ViewWeights w1 = select(m, 0, 0, 1);
  EXPECT_NEAR(w1.weight[1], 2 * psi[1], 1e-6);
  EXPECT_NEAR(w1.weight[5], psi[5], 1e-6);
  EXPECT_EQ(w1.best_view, 5);
  const double want = (2 * psi[1] * m.at(0, 1) + psi[5] * m.at(0, 5) + psi[3] * m.at(0, 3) +
                       psi[0] * m.at(0, 0)) /
                      (2 * psi[1] + psi[5] + psi[3] + psi[0]);
  EXPECT_NEAR(aggregateCost(paperParams(), w1, m.row(0), m.views), want, 1e-6);
}

TEST(ViewSelection, PreviouslySelectedViewNotGoodNowWeighsPointTwo) {
  const std::vector<std::vector<double>> columns = {
      {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8},  // good
      {1.5, 1.5, 1.5, 1.5, 1.5, 1.5, 1.5, 1.5},  // bad, selected last time: 0.2
      {1.6, 1.6, 1.6, 1.6, 1.6, 1.6, 1.6, 1.6},  // bad, not selected: 0
      {0.2, 0.2, 0.3, 0.3, 0.9, 0.9, 0.9, 0.9},  // good and selected last time: psi
      {1.4, 1.4, 1.4, 1.4, 1.4, 1.4, 1.4, 1.4},  // bad, last best view and selected: 0.2, no boost
  };
  const Matrix m(columns);
  const uint32_t previous = (1u << 1) | (1u << 3) | (1u << 4);
  const ViewWeights w = select(m, 2, previous, 4);
  const double psi0 = meanOf(columns[0]), psi3 = meanOf(columns[3]);
  EXPECT_FALSE(w.heuristic);
  EXPECT_NEAR(w.weight[0], psi0, 1e-6);
  EXPECT_NEAR(w.weight[1], 0.2, 1e-7);
  EXPECT_EQ(w.weight[2], 0.0f);
  EXPECT_NEAR(w.weight[3], psi3, 1e-6);
  EXPECT_NEAR(w.weight[4], 0.2, 1e-7);
  // Only views of S_t are carried to the next iteration.
  EXPECT_EQ(w.selected, (1u << 0) | (1u << 3));
  EXPECT_EQ(w.best_view, psi0 > psi3 ? 0 : 3);
  for (int i = 0; i < m.rows; ++i) {
    const double want = (psi0 * m.at(i, 0) + 0.2 * m.at(i, 1) + psi3 * m.at(i, 3) +
                         0.2 * m.at(i, 4)) /
                        (psi0 + 0.2 + psi3 + 0.2);
    EXPECT_NEAR(aggregateCost(paperParams(), w, m.row(i), m.views), want, 1e-6) << "row " << i;
  }
}

TEST(ViewSelection, TiesKeepLowerViewIndices) {
  const std::vector<double> same = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8};
  const Matrix m({same, same, same, same, same, same});
  const ViewWeights w = select(m, 0);
  EXPECT_EQ(w.selected, 0xFu);
  EXPECT_EQ(w.best_view, 0);
}

TEST(ViewSelection, FewerRowsAverageOverThoseRows) {
  // A border pixel with 4 hypotheses: psi is the mean over the 4.
  const std::vector<std::vector<double>> columns = {{0.1, 0.2, 0.3, 1.0}, {0.0, 0.5, 0.6, 1.3}};
  const Matrix m(columns);
  const ViewWeights w = select(m, 1);
  EXPECT_NEAR(w.weight[0], (C(0.1) + C(0.2) + C(0.3) + C(1.0)) / 4, 1e-6);
  EXPECT_NEAR(w.weight[1], (C(0.0) + C(0.5) + C(0.6) + C(1.3)) / 4, 1e-6);
}

TEST(ViewSelection, NoGoodViewFallsBackToHeuristicWithoutNaN) {
  const std::vector<double> bad(8, 2.0);
  const Matrix m({bad, bad, bad, bad, bad});
  const ViewWeights w = select(m, 0);
  EXPECT_TRUE(w.heuristic);
  EXPECT_EQ(w.selected, 0u);
  EXPECT_EQ(w.best_view, kNoView);
  for (int j = 0; j < 5; ++j) EXPECT_EQ(w.weight[j], 0.0f) << "view " << j;
  const SelectionParams p = paperParams();
  // Mean of the heuristic_k = 3 smallest: (0.1 + 0.3 + 0.9) / 3.
  const float row[5] = {1.5f, 0.3f, 2.0f, 0.9f, 0.1f};
  EXPECT_NEAR(aggregateCost(p, w, row, 5), (0.1 + 0.3 + 0.9) / 3, 1e-6);
  EXPECT_EQ(aggregateCost(p, w, m.row(0), 5), 2.0f);
  // Fewer views than K: mean of all of them.
  EXPECT_NEAR(aggregateCost(p, w, row, 2), (1.5 + 0.3) / 2, 1e-6);
  // No view at all: the maximum cost, not 0/0.
  EXPECT_EQ(aggregateCost(p, w, row, 0), kMaxCost);
}

TEST(ViewSelection, ZeroRowsGiveNoNaN) {
  const float unused[kStride] = {};
  ViewWeights w;
  jointViewSelection(paperParams(), unused, 0, kStride, 3, 2, 0, kNoView, &w);
  EXPECT_TRUE(w.heuristic);
  EXPECT_EQ(w.best_view, kNoView);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(w.weight[j], 0.0f);
  const float costs[3] = {0.7f, 0.2f, 0.4f};
  const float c = aggregateCost(paperParams(), w, costs, 3);
  EXPECT_FALSE(std::isnan(c));
  EXPECT_NEAR(c, (0.7 + 0.2 + 0.4) / 3, 1e-6);

  // With a view selected last time it carries 0.2 alone: its cost, exactly.
  jointViewSelection(paperParams(), unused, 0, kStride, 3, 2, 1u << 1, 1, &w);
  EXPECT_FALSE(w.heuristic);
  EXPECT_NEAR(w.weight[1], 0.2, 1e-7);
  EXPECT_EQ(w.best_view, kNoView);
  EXPECT_FLOAT_EQ(aggregateCost(paperParams(), w, costs, 3), 0.2f);
}

}  // namespace
}  // namespace mvs
}  // namespace amhmvs
