#include "amhmvs_mapping/mapping/map_pose_correction.h"

#include <cmath>
#include <utility>
#include <vector>

#include "amhmvs_mapping/mapping/keyframe_pose_graph.h"

namespace amhmvs {

void MapPoseCorrection::record(int64_t id, const DepthProblem& problem, const PoseRefinementResult& refinement) {
  for (size_t i = 0; i < refinement.sources.size() && i < problem.source_keys.size(); ++i) {
    const SourcePoseOutcome outcome = refinement.sources[i].outcome;
    if (outcome == SourcePoseOutcome::kRefined || outcome == SourcePoseOutcome::kConfirmed)
      refined_.record(id, problem.reference_camera, problem.source_keys[i], problem.source_cameras[i]);
    else
      refined_.drop(id, problem.source_keys[i]);
  }
}

Eigen::Isometry3d MapPoseCorrection::mapPose(int64_t id, const KeyframeStore& store) const {
  const auto corrected = corrected_.find(id);
  return corrected != corrected_.end() ? corrected->second : store.keyframe(id).cameraToWorld();
}

void MapPoseCorrection::solvePoseGraph(const KeyframeStore& store, const PoseRefinementOptions& options,
                                       MapUpdater* map) {
  if (!options.correct_map_poses) return;
  std::map<int64_t, Eigen::Isometry3d> tracker_poses;
  for (int64_t id : store.ids()) tracker_poses[id] = store.keyframe(id).cameraToWorld();
  std::vector<KeyframePoseGraphEdge> edges;
  for (const auto& pair : refined_.pairs()) edges.push_back({pair.first.first, pair.first.second, pair.second});
  constexpr double kDegree = M_PI / 180;
  KeyframePoseGraphSettings settings;
  settings.prior_position_sigma_m = options.prior_position_sigma_m;
  settings.prior_rotation_sigma_rad = options.prior_rotation_sigma_deg * kDegree;
  settings.rotation_sigma_rad = options.graph_rotation_sigma_deg * kDegree;
  settings.direction_sigma_rad = options.graph_direction_sigma_deg * kDegree;
  corrected_ = solveKeyframePoseGraph(tracker_poses, edges, settings);
  moveMapKeyframes(map);
}

bool MapPoseCorrection::adjust(int64_t id, const PoseRefiner& refiner, const KeyframeStore& store,
                               DepthProblem* problem, MapUpdater* map) {
  std::map<int64_t, PinholeCamera> cameras;
  for (int64_t stored : store.ids()) cameras[stored] = store.keyframe(stored).camera;
  const KeyframeBundleAdjustmentResult adjusted = refiner.adjustKeyframes(cameras);
  if (!adjusted.solved) return false;
  // Every refined pair of two adjusted keyframes at their adjusted relative pose.
  std::vector<std::pair<int64_t, int64_t>> pairs;
  for (const auto& pair : refined_.pairs()) pairs.push_back(pair.first);
  for (const auto& pair : pairs) {
    const auto first = adjusted.poses.find(pair.first), second = adjusted.poses.find(pair.second);
    if (first == adjusted.poses.end() || second == adjusted.poses.end()) continue;
    PinholeCamera reference = cameras.at(pair.first), source = cameras.at(pair.second);
    setCameraToWorld(first->second, &reference);
    setCameraToWorld(second->second, &source);
    refined_.record(pair.first, reference, pair.second, source);
  }
  for (size_t s = 0; s < problem->source_keys.size(); ++s)
    refined_.place(id, problem->reference_camera, problem->source_keys[s], &problem->source_cameras[s]);
  corrected_ = adjusted.poses;
  moveMapKeyframes(map);
  return true;
}

void MapPoseCorrection::moveMapKeyframes(MapUpdater* map) {
  // Each solve moves every keyframe a little; re-posing all points for
  // changes far below the map's voxels would cost more than the pose
  // refinement itself: a keyframe moves when it is off by 1 mm or 1e-4 rad
  // (0.5 mm at 5 m), else it stays where it is placed.
  constexpr double kMinShiftM = 1e-3, kMinTurnRad = 1e-4;
  const VoxelMap& placed_map = map->map();  // after the update in flight
  for (auto& entry : corrected_) {
    if (!placed_map.contains(entry.first)) continue;
    const Eigen::Isometry3d& placed = placed_map.pose(entry.first);
    const bool moved = (placed.translation() - entry.second.translation()).norm() >= kMinShiftM ||
                       Eigen::AngleAxisd(placed.linear().transpose() * entry.second.linear()).angle() >= kMinTurnRad;
    if (!moved) {
      entry.second = placed;
      continue;
    }
    map->updatePose(entry.first, entry.second);
  }
}

void MapPoseCorrection::forget(int64_t id) {
  refined_.forget(id);
  corrected_.erase(id);
}

void MapPoseCorrection::clear() {
  refined_.clear();
  corrected_.clear();
}

}  // namespace amhmvs
