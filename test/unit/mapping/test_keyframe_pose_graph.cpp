// The keyframe pose graph (keyframe_pose_graph.h): exact relative poses and
// noisy tracker poses give keyframes that agree with each other as the
// relative poses say, at the tracker's mean placement; keyframes without an
// edge keep the tracker's pose.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "amhmvs_mapping/mapping/keyframe_pose_graph.h"

namespace amhmvs {
namespace {

constexpr double kDegree = M_PI / 180;

Eigen::Isometry3d pose(const Eigen::Vector3d& turn, const Eigen::Vector3d& centre) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  if (turn.norm() > 0) out.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
  out.translation() = centre;
  return out;
}

double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() / kDegree;
}

struct Walk {
  std::map<int64_t, Eigen::Isometry3d> truth, tracker;
  std::vector<KeyframePoseGraphEdge> edges;  // exact
};

// 8 keyframes 0.25 m apart along a turning path; the tracker off by 1 cm and
// 0.3 degrees per axis; each keyframe linked to the next three.
Walk walk() {
  Walk w;
  std::mt19937 random(7);
  std::normal_distribution<double> normal(0, 1);
  const auto noise = [&](double sigma) -> Eigen::Vector3d { return Eigen::Vector3d(normal(random), normal(random), normal(random)) * sigma; };
  for (int64_t id = 0; id < 8; ++id) {
    w.truth[id] = pose(Eigen::Vector3d(0.02 * id, 0.1 * id, 0), Eigen::Vector3d(0.25 * id, 0.03 * id * id, 0));
    Eigen::Isometry3d tracked = pose(noise(0.3 * kDegree), Eigen::Vector3d::Zero()) * w.truth[id];
    tracked.translation() = w.truth[id].translation() + noise(0.01);
    w.tracker[id] = tracked;
  }
  for (int64_t i = 0; i < 8; ++i)
    for (int64_t j = i + 1; j < std::min<int64_t>(8, i + 4); ++j)
      w.edges.push_back({i, j, w.truth[j].inverse() * w.truth[i]});
  return w;
}

TEST(KeyframePoseGraph, ExactRelativePosesMakeTheKeyframesAgree) {
  if (!keyframePoseGraphAvailable()) GTEST_SKIP() << "this build has no Ceres";
  const Walk w = walk();
  const std::map<int64_t, Eigen::Isometry3d> corrected =
      solveKeyframePoseGraph(w.tracker, w.edges, KeyframePoseGraphSettings());
  ASSERT_EQ(corrected.size(), 8u);
  double worst_tracker_deg = 0, worst_corrected_deg = 0, worst_tracker_m = 0, worst_corrected_m = 0;
  for (const KeyframePoseGraphEdge& edge : w.edges) {
    const Eigen::Isometry3d truth = w.truth.at(edge.source).inverse() * w.truth.at(edge.reference);
    const Eigen::Isometry3d tracker = w.tracker.at(edge.source).inverse() * w.tracker.at(edge.reference);
    const Eigen::Isometry3d solved = corrected.at(edge.source).inverse() * corrected.at(edge.reference);
    worst_tracker_deg = std::max(worst_tracker_deg, angleDeg(truth.linear(), tracker.linear()));
    worst_corrected_deg = std::max(worst_corrected_deg, angleDeg(truth.linear(), solved.linear()));
    worst_tracker_m = std::max(worst_tracker_m, (truth.translation() - tracker.translation()).norm());
    worst_corrected_m = std::max(worst_corrected_m, (truth.translation() - solved.translation()).norm());
  }
  std::printf("relative poses, worst: tracker %.3f deg %.1f mm, corrected %.4f deg %.2f mm\n", worst_tracker_deg,
              1000 * worst_tracker_m, worst_corrected_deg, 1000 * worst_corrected_m);
  EXPECT_GT(worst_tracker_deg, 0.3);
  EXPECT_LT(worst_corrected_deg, 0.01);
  // The baselines' common scale comes from the tracker's noisy centres: a
  // few millimetres over metres, where the tracker's pairs are off by centimetres.
  EXPECT_GT(worst_tracker_m, 0.02);
  EXPECT_LT(worst_corrected_m, 0.005);
  // The whole graph stays where the tracker put it on average: each
  // keyframe within the tracker's noise of the truth.
  for (const auto& entry : corrected) {
    EXPECT_LT(angleDeg(entry.second.linear(), w.truth.at(entry.first).linear()), 0.6) << entry.first;
    EXPECT_LT((entry.second.translation() - w.truth.at(entry.first).translation()).norm(), 0.02) << entry.first;
  }
}

TEST(KeyframePoseGraph, KeyframesWithoutEdgesKeepTheTrackersPose) {
  if (!keyframePoseGraphAvailable()) GTEST_SKIP() << "this build has no Ceres";
  Walk w = walk();
  w.tracker[42] = pose(Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(5, 5, 5));
  w.edges.push_back({3, 99, Eigen::Isometry3d::Identity()});  // 99 is not a keyframe of the graph: ignored
  const std::map<int64_t, Eigen::Isometry3d> corrected =
      solveKeyframePoseGraph(w.tracker, w.edges, KeyframePoseGraphSettings());
  ASSERT_EQ(corrected.count(42), 1u);
  EXPECT_TRUE(corrected.at(42).matrix() == w.tracker.at(42).matrix());
  EXPECT_EQ(corrected.count(99), 0u);
  // No edges at all: the tracker's poses, bit for bit.
  const std::map<int64_t, Eigen::Isometry3d> alone = solveKeyframePoseGraph(w.tracker, {}, KeyframePoseGraphSettings());
  for (const auto& entry : w.tracker) EXPECT_TRUE(alone.at(entry.first).matrix() == entry.second.matrix());
}

}  // namespace
}  // namespace amhmvs
