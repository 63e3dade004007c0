// What amhmvs_map writes, off the pipeline's critical path: every pipeline
// output is copied into a job of the writer thread, which writes its depth
// map, preview and fused clouds, compares the depth with the recording's
// ground truth, appends a row to keyframes.csv / keyframes.jsonl and prints
// the progress line. finish() writes map.ply and summary.json.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/eval/depth_metrics.h"
#include "amhmvs_mapping/io/background_writer.h"
#include "amhmvs_mapping/io/posed_sequence.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "map_options.h"

namespace amhmvs {

// Counts of one run that the tool knows and the pipeline does not.
struct MapRunTotals {
  size_t frames_looked_at = 0;
  size_t keyframes_picked = 0;
  KeyframePickerStats picking;  // refusals by reason
  size_t keyframes_pushed = 0;
  double wall_s = 0;       // first push to last output
  double reading_s = 0;    // decoding and scaling images (before push)
  std::string interrupted_by;  // "SIGINT" / "SIGTERM" when a stop request ended the reading early
};

class MapOutputs {
 public:
  // Creates the folders and the log files; throws InputError when it cannot.
  MapOutputs(const std::string& dir, const MapToolOptions& options, const PosedSequence& sequence);
  ~MapOutputs();

  // Queues the outputs of one result (main thread).
  void add(const PipelineOutput& output);
  // Waits for the writer, then writes map.ply and summary.json. Returns a
  // one-line summary for people.
  std::string finish(const MappingPipeline& pipeline, const MapRunTotals& totals);

 private:
  struct Row;
  // Writer thread: the files, the comparison, the log rows and progress line of one result.
  void write(const Row& row);
  void writeFiles(const KeyframeResult& result);
  void writeDepth(int64_t id, const ImageF& depth, const DepthRangeEstimate& range);
  // True when depth maps are written (published) when their keyframe is
  // fused, masked by the confidence; false: when estimated, unmasked.
  bool publishesWhenFused() const;
  // keyframe_poses.txt: where the map placed each keyframe (TUM format, by stamp).
  void writeKeyframePoses(const VoxelMap& map) const;
  // The published depth maps of the keyframes `result` fused against ground
  // truth (kept per keyframe); their rows as a JSON list.
  std::string comparePublished(const KeyframeResult& result);
  // False when the result has no depth map or its frame no ground truth.
  bool compareWithTruth(const KeyframeResult& result, const PosedFrame* frame, DepthComparison* comparison);
  // summary.json's text; `line`: the same in one line of prose.
  std::string summaryJson(const MappingPipeline& pipeline, const MapRunTotals& totals, std::string* line);

  std::string dir_;
  MapToolOptions options_;
  const PosedSequence& sequence_;
  std::map<int64_t, size_t> frame_of_id_;
  size_t results_ = 0;
  // Writer thread state (read by the main thread only after finish()).
  std::FILE* csv_ = nullptr;
  std::FILE* jsonl_ = nullptr;
  std::map<std::string, size_t> kinds_;
  std::map<int64_t, DepthComparison> accuracy_;  // latest depth map of each keyframe
  std::map<int64_t, DepthComparison> published_accuracy_;  // latest published depth map of each keyframe
  // The same on the weakly textured pixels only (eval/depth_metrics.h), with
  // each keyframe's mask at the processed size.
  std::map<int64_t, ImageU8> weak_texture_masks_;
  std::map<int64_t, DepthComparison> weak_accuracy_, weak_published_accuracy_;
  std::map<int64_t, DepthRangeEstimate> depth_ranges_;  // of each keyframe's latest depth map (previews)
  std::map<int64_t, size_t> keyframe_pixels_;  // of each keyframe with a depth map, at the processed size
  std::map<int64_t, std::vector<Eigen::Vector3f>> truth_points_;  // true surface, world (trueSurfaceView)
  // Where the recording has true poses apart from the tracker's: the exact
  // depth placed at the tracker's poses (what the pose error alone leaves of
  // a perfect map).
  std::map<int64_t, std::vector<Eigen::Vector3f>> tracker_placed_truth_;
  std::map<int64_t, Eigen::Isometry3d> tracker_poses_;  // camera-to-world, of those
  std::map<int64_t, Eigen::Isometry3d> true_poses_;     // camera-to-world, of those
  std::vector<double> total_ms_, estimate_ms_;
  std::vector<double> pose_refinement_ms_;          // results whose poses were refined
  std::map<std::string, size_t> pose_outcomes_;     // sources by SourcePoseOutcome name
  std::vector<double> direct_alignment_ms_;         // results whose sources were aligned
  std::map<std::string, size_t> alignment_outcomes_;  // sources by SourceAlignmentOutcome name
  double submit_blocked_ms_ = 0;  // main thread: time add() waited for room in the writer's queue
  BackgroundWriter writer_;  // last: stopped first
};

}  // namespace amhmvs
