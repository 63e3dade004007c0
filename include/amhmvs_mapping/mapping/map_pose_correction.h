#pragma once

#include <cstdint>
#include <map>

#include <Eigen/Geometry>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/map_updater.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "amhmvs_mapping/mapping/refined_relative_poses.h"

namespace amhmvs {

// Where the map places each keyframe: at the tracker's pose, or corrected
// from what the pose refinement found between keyframes (a pose graph over
// the refined relative poses, or the keyframe bundle adjustment). Keeps those
// relative poses for the stereo and fusion of later keyframes too.
class MapPoseCorrection {
 public:
  // The estimate's refined (or confirmed) source poses become relative poses;
  // the others are dropped.
  void record(int64_t id, const DepthProblem& problem, const PoseRefinementResult& refinement);
  // `view`'s camera as refined relative to keyframe `id` at `reference`;
  // false (camera unchanged) when there is no refined pose between them.
  bool placeView(int64_t id, const PinholeCamera& reference, int64_t view, PinholeCamera* camera) const {
    return refined_.place(id, reference, view, camera);
  }

  // Corrects the map's poses by a pose graph over the relative poses (when
  // options.correct_map_poses) and moves the keyframes of `map` that moved.
  void solvePoseGraph(const KeyframeStore& store, const PoseRefinementOptions& options, MapUpdater* map);
  // The keyframe bundle adjustment of every stored keyframe: its poses for
  // the map, its relative poses for stereo, and `problem`'s source cameras
  // placed from them. False when it did not solve (nothing changed).
  bool adjust(int64_t id, const PoseRefiner& refiner, const KeyframeStore& store, DepthProblem* problem,
              MapUpdater* map);

  // The pose the map places keyframe `id` at.
  Eigen::Isometry3d mapPose(int64_t id, const KeyframeStore& store) const;
  void dropCorrection(int64_t id) { corrected_.erase(id); }  // a new tracker pose: the next graph starts from it
  void forget(int64_t id);  // evicted: its points stay in the map where they are
  void clear();

 private:
  void moveMapKeyframes(MapUpdater* map);

  RefinedRelativePoses refined_;
  std::map<int64_t, Eigen::Isometry3d> corrected_;
};

}  // namespace amhmvs
