// The online mapping pipeline, one keyframe at a time (ROS-free; the mapping
// nodelet is a thin layer on top of it):
//
//   1. store the keyframe (KeyframeStore, bounded);
//   2. choose its source views among the stored keyframes (selectSources);
//      none: it is kept as a source for later keyframes (an all-NaN depth
//      map, no normals) and waits for sources: estimateLate() gives it a
//      depth map (steps 2-6) once later keyframes qualify as its sources
//      (the first keyframe of a run gets its depth map after the second);
//   3. its depth range (estimateDepthRange: given, sparse points, the
//      sources' depth maps, default);
//   4. its depth map (the injected estimate function: the caller's backend
//      with its fallbacks);
//   5. deferred fusion: the keyframe now waits as "estimated, not fused".
//      Every time a depth map finishes (this keyframe's included), each
//      waiting keyframe, oldest first, is re-checked: its consistency views
//      are the OTHER keyframes with a depth map (earlier or later ones) that
//      pass source selection's geometric checks against it (selectSources
//      among them, best first, at most max(sources.max_sources,
//      fusion.min_consistent_views)). Once there are at least
//      fusion.min_consistent_views of them (at least 1; the requirement is
//      never capped to the views there are), its depth map is fused against
//      them (fuseDepthMaps) and its fused points (camera frame) are stored
//      with it; fused with fewer views than the confidence counts (the first
//      keyframes of a run), it is fused again by fuseAgain() once more views
//      see it, during the next 8 depth maps (confidence.again_with_more_views);
//   6. those points into the global VoxelMap at the keyframe's current pose;
//      with surface.enabled its published depth (step 7) into the TSDF
//      surface map too (its mesh extracted again where it changed when read);
//   7. with confidence.enabled, when it is fused: its calibrated per-pixel
//      confidence against the same consistency views and its depth map as
//      published, masked below confidence.min_probability
//      (depth_confidence.h; FusedKeyframe::published);
//   8. with depth_filter.enabled (temporal_depth.h, not in the paper): its
//      first depth map starts a per-pixel depth filter that every later
//      frame refines (the next keyframes, and the frames between them given
//      to observe()), while it is among the depth_filter.keyframes newest;
//      its depth is published again every depth_filter.publish_every frames
//      (KeyframeResult::refined_depths).
//
// Refinement (refine()): a keyframe's sources are chosen among the keyframes
// stored when it is estimated, so early keyframes of a run, and any keyframe
// whose best partners come later, get a weaker selection than the store
// offers later. refine() re-estimates such a keyframe (at most
// refinement.max_refinements times) once its selection now would score at
// least refinement.min_score_gain times the one it was estimated with, and
// fuses it again (its map points are replaced) -- when the new depth map is
// not worse by the estimator's own evidence (refinement_evidence.h:
// confident pixels; refinement.keep_only_better); otherwise the keyframe
// keeps its depth map and fusion (result.refinement_rejected). With
// refinement.fuse_neighbours_again, once nothing is left to refine, refine()
// fuses again each keyframe whose last fusion checked against a depth map
// that a refinement has replaced since (one per call, result.fused_again).
// One call chooses the sources of at most kSelectionsPerRefineCall keyframes
// anew, those nearest the newest keyframe first (a selection can only gain
// from keyframes near it): an idle step costs about the same in a store of
// 50 keyframes and of 5,000.
//
// So the second keyframe of a run, which has one depth map to be checked
// against, waits until enough later depth maps exist; the last keyframes of a
// run may still wait when input stops (waitingForFusion()). A waiting
// keyframe evicted from the store is never fused (evictedBeforeFusion()).
// With pose_refinement.correct_map_poses the map places each keyframe at
// its pose from the keyframe pose graph (keyframe_pose_graph.h), solved again
// after each pose refinement (points moved exactly, as for a loop closure).
// With pose_refinement.keyframe_bundle_adjustment instead, one bundle
// adjustment over the matches of all stored keyframes
// (keyframe_bundle_adjustment.h) gives the map poses, the sources' poses of
// the stereo and the relative poses of the fusion; a keyframe whose sources
// it has moved since the estimate is estimated again (in refine(), up to
// pose_refinement.max_pose_reestimates times; reported as a refinement).
// Loop closure: updatePose() re-poses the keyframe in the store and moves its
// points in the map exactly (remove with the old pose, add with the new one);
// a waiting keyframe is fused later with the pose it has then.
// Keyframes evicted from the store stay in the map (the map has its own
// bounds and keeps their points, so they can still be re-posed).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/serial_worker.h"
#include "amhmvs_mapping/mapping/consistency_fusion.h"
#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/depth_range.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/fusion_schedule.h"
#include "amhmvs_mapping/mapping/map_pose_correction.h"
#include "amhmvs_mapping/mapping/map_updater.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/neighbour_depth.h"
#include "amhmvs_mapping/mapping/direct_alignment.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"
#include "amhmvs_mapping/mapping/rolling_shutter_rectifier.h"
#include "amhmvs_mapping/mapping/source_selection.h"
#include "amhmvs_mapping/mapping/temporal_depth.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct RefinementOptions {
  int max_refinements = 1;       // re-estimations per keyframe; 0 = off
  // Re-estimate when the selection's total score (sum of the sources'
  // overlap x G(angle)) grew by this factor since the estimate (> 1).
  double min_score_gain = 1.25;
  // Keep a refined depth map only when it is not worse by the estimator's
  // evidence (judgeRefinement: confident pixels, cost (0..2) <=
  // confident_cost, at least (1 - max_confident_loss) times the old map's;
  // false: always replace). Off by default: more sources raise the
  // aggregated cost even where they help, so this evidence rejected good
  // refinements and shrank the maps of the temple and redkitchen bags
  // (rostests replay_map: 882 / 1018 map points against floors of 1200 / 2400).
  bool keep_only_better = false;
  // Keyframes fused against a depth map that a refinement then replaced are
  // fused again (idle work, after the refinements): their agreement was
  // checked against the old map (the last keyframe of a run is never refined
  // itself, but its consistency views are). Off by default: README
  // "Settings that matter behind a real tracker" says why.
  bool fuse_neighbours_again = false;
  double confident_cost = 0.5;
  double max_confident_loss = 0.02;

  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// The online fusion: the reprojection preset (2 px, 10 deg, 2 views) with 2 %
// relative depth instead of 1 %, chosen from the measured curve (README,
// "Confidence and the published depth"): pose errors of 1-3 px move depths by
// more than 1 % at short baselines; on redkitchen 4884 map points, 90.8 %
// within 5 cm (1 %: 3160, 94.8 %); on the realism-mode room with 1 px pose
// error 6374 points, 77.7 % (3092, 65.6 %).
FusionOptions onlineFusionOptions();

struct OnlineMapperOptions {
  KeyframeStoreOptions store;
  SourceSelectionOptions sources;
  DepthRangeOptions depth_range;
  FusionOptions fusion = onlineFusionOptions();
  VoxelMapOptions map;
  RefinementOptions refinement;
  ConfidenceOptions confidence;
  // The sources' poses relative to the keyframe refined before its estimate
  // (pose_refinement.h); for the stereo only: the store, depth maps, fusion
  // and map keep the tracker's poses.
  PoseRefinementOptions pose_refinement;
  // Direct (photometric) alignment of the sources that have depth maps to
  // the keyframe before stereo (direct_alignment.h), before pose_refinement.
  DirectAlignmentOptions direct_alignment;
  // Starts and geometric refinements from the neighbours' depth maps (off).
  NeighbourDepthOptions neighbour_depth;
  // Rolling-shutter rectification of each keyframe's image before it is
  // stored (off: readout_s 0), with the angular velocity from the tracker's
  // poses of it and the keyframe before it.
  RollingShutterOptions rolling_shutter;
  // Step 8: the temporal depth filter (off).
  TemporalDepthOptions depth_filter;
  // Step 6 also integrates each fused keyframe's published depth (weighted by
  // its confidence, with the keyframe's colours) into a TSDF surface map
  // and extracts its mesh where it changed (tsdf_map.h). Without
  // confidence.enabled there is no published depth and no surface map.
  TsdfMapOptions surface;
  // The voxel-map update of a fused keyframe runs on a worker thread while
  // the caller goes on (with a GPU estimator: while the next keyframe is
  // estimated, when the CPU would otherwise wait); every later use of the
  // map waits for it first, so what callers see does not change.
  bool map_in_background = true;

  // Empty when valid; otherwise one line per problem, prefixed by the group.
  std::string validate() const;
};

// Appends each line of a group's validate() to `out`, prefixed "group: ".
void appendProblems(const std::string& group, const std::string& problems, std::ostringstream* out);

// The surface map the mapper keeps: surface, enabled only with
// confidence.enabled too (it integrates the published depth).
TsdfMapOptions keptSurface(const OnlineMapperOptions& options);

// Depth estimation as the mapper calls it. Throws like DepthEstimator::estimate.
// Problems carry keyframe ids as image keys: an estimator that keeps images
// resident (the CUDA DepthEstimator) must be told forget(id) for every
// evicted keyframe and forgetAll() on reset (ids may be reused), as
// MappingPipeline does.
using EstimateFunction = std::function<DepthMap(const DepthProblem&)>;

// One keyframe fused into the map.
struct FusedKeyframe {
  int64_t id = 0;
  double stamp = 0;                     // the keyframe's stamp
  PinholeCamera camera;                 // the pose it was fused with
  std::vector<int64_t> consistency_ids;  // the other depth maps it was checked against
  bool again = false;                   // fused before (refined), with or without points: they are replaced
  Shared<KeyframePoints> points;        // fused points, camera frame (shared with the store and the map)
  PublishedDepth published;             // with confidence.enabled: the depth map as published, its confidence
};

// Wall-clock milliseconds of the stages of one result (0 where a stage did
// not run).
struct StageTimes {
  double queue_wait_ms = 0;    // from MappingPipeline::push() to the start of processing
  double selection_ms = 0;     // source views
  double depth_range_ms = 0;
  double problem_ms = 0;       // the depth problem (cameras, grey images)
  double direct_alignment_ms = 0;  // the sources' poses aligned photometrically
  double pose_refinement_ms = 0;  // the sources' poses refined (features, matches, bundle adjustment)
  double estimate_ms = 0;      // the estimator, wall clock (its own time: DepthMap::milliseconds)
  double store_ms = 0;         // copies into the keyframe store (keyframe, depth map, fused points)
  double fusion_ms = 0;        // consistency views and checks of the keyframes fused by this result
  double confidence_ms = 0;    // their confidence and published depth (confidence.enabled)
  double map_ms = 0;           // voxel map updates, or waiting for the one in the background
  double depth_filter_ms = 0;  // step 8: filters started and refined by this keyframe
  // A deferred fusion that ran during this estimate (process(..., next_follows)),
  // wall clock: inside estimate_ms; its parts are in store, fusion, confidence and map too.
  double fused_during_estimate_ms = 0;
  double total_ms = 0;         // the whole call (without queue_wait_ms)
};

// What process() did with one keyframe.
struct KeyframeResult {
  int64_t id = 0;
  bool late = false;             // from estimateLate(): a keyframe that arrived earlier
  bool refined = false;          // from refine(): a new depth map of an earlier keyframe
  bool fused_again = false;      // from fuseAgain(): an earlier keyframe fused again, no new depth map
  bool deferred_fusion = false;  // from fuseDeferred(): earlier depth maps fused, no new depth map
  bool frame_only = false;       // from a frame between keyframes (observe()): refined_depths only
  // refine(): the new depth map was worse by the estimator's evidence and was
  // dropped; the keyframe keeps its depth map and points (`depth` is the
  // dropped one, nothing was fused). refinement_evidence says why.
  bool refinement_rejected = false;
  std::string refinement_evidence;
  SourceSelection selection;
  bool has_depth = false;        // false: no source view (yet), stored as a source only
  DepthRangeEstimate depth_range;  // when has_depth
  DirectAlignmentResult direct_alignment;  // when has_depth: the sources aligned before the estimate
  PoseRefinementResult pose_refinement;  // when has_depth: the sources' poses used by the estimate
  Shared<DepthMap> depth;        // when has_depth (shared with the keyframe store)
  PinholeCamera camera;          // the keyframe's camera (pose used)
  // Every keyframe fused by this call, in fusion order (oldest waiting
  // first): earlier waiting keyframes that this depth map completed, and
  // this keyframe when it had enough consistency views at once.
  std::vector<FusedKeyframe> fused;
  bool fused_now = false;        // this keyframe is among `fused`
  // Step 8: keyframes whose depth is published again, refined by the frames
  // since (this keyframe among them).
  std::vector<RefinedDepth> refined_depths;
  std::vector<int64_t> evicted;  // keyframes evicted from the store
  std::vector<int64_t> evicted_before_fusion;  // of those, the ones that waited for fusion
  size_t waiting_for_fusion = 0;  // keyframes waiting after this call
  StageTimes times;
};

class OnlineMapper {
 public:
  // Throws InputError when the options are invalid or estimate is empty.
  // Without a fuse function the mapper fuses with fuseDepthMaps (CPU);
  // without a publish function the confidence and the published depth are
  // computed with publishDepth (CPU).
  OnlineMapper(const OnlineMapperOptions& options, EstimateFunction estimate, FuseFunction fuse = FuseFunction(),
               PublishFunction publish = PublishFunction());
  ~OnlineMapper();  // waits for a map update in the background
  OnlineMapper(const OnlineMapper&) = delete;
  OnlineMapper& operator=(const OnlineMapper&) = delete;

  // Runs steps 1-6 for a keyframe. Throws InputError for an invalid keyframe
  // (nothing changes); an exception of the estimate function propagates after
  // the keyframe was removed from the store again.
  //
  // next_follows: the caller will process another keyframe at once (its
  // queue holds one). Step 5 for this depth map then waits for that call,
  // which runs it on this thread while its own estimate runs on a worker
  // thread: with a GPU estimator the fusion of keyframe k (its checks,
  // confidence, downloads and map update) overlaps the estimate of k + 1.
  // The results are those of fusing at once (the next keyframe's problem
  // reads depth maps, not fusion), delivered in the next call's `fused`.
  // A deferred fusion runs at once instead when it could evict the next
  // keyframe's source images from the store (a full store of pending work)
  // and before any other call that estimates; fuseDeferred() runs it
  // alone (when the next keyframe did not come after all).
  KeyframeResult process(Keyframe keyframe, bool next_follows = false);

  // Runs a fusion that process(..., next_follows = true) deferred
  // (result->deferred_fusion; no new depth map). False when none waits.
  // estimateLate() and refine() run a deferred fusion first when they have
  // a keyframe to estimate (its outcome comes with theirs), fuseAgain() as
  // its work.
  bool fuseDeferred(KeyframeResult* result);
  bool fusionDeferred() const {
    return deferred_.pending || !deferred_.undelivered.fused.empty() || !deferred_.undelivered.evicted.empty();
  }

  // A frame between keyframes (its image and camera as a keyframe's; no id of
  // the store): with depth_filter.enabled it refines the depth of the newest
  // keyframes (step 8). Returns the depths due to be published again.
  // Throws InputError for an image that does not fit its camera.
  std::vector<RefinedDepth> observe(const Keyframe& frame);

  // Stores a keyframe as a source view only: no depth map of its own, ever
  // (e.g. one skipped for a newer keyframe while estimation lags behind).
  // Returns the keyframes evicted from the store. Throws InputError for an
  // invalid keyframe (nothing changes).
  std::vector<int64_t> addSourceView(Keyframe keyframe);

  // Keyframes that had no source view when they arrived are re-checked,
  // oldest first; the first that has sources now gets its depth map and
  // fusion as in process() (result->late is true). At most one per call, so
  // that a caller can interleave them with new keyframes. False (result
  // untouched) when none qualifies. An exception of the estimate function
  // propagates; that keyframe then stays a source only and is not retried.
  bool estimateLate(KeyframeResult* result);

  // Re-estimates one keyframe whose source selection improved enough since
  // its depth map was computed (see Refinement above), oldest first; its
  // depth map is replaced and it is fused again (result->refined is true),
  // unless the new one is worse (result->refinement_rejected).
  // False (result untouched) when none qualifies. An exception of the
  // estimate function propagates; the keyframe keeps its depth map and is
  // not refined again.
  bool refine(KeyframeResult* result);
  static constexpr int kSelectionsPerRefineCall = 16;

  // With confidence.again_with_more_views (the confidence on or off; off:
  // nothing is published, the points are replaced): fuses and publishes
  // again one keyframe that was fused with fewer consistency views than the
  // confidence counts (calibration.max_views; the first keyframes of a run,
  // fused with two views, where no pixel reaches 0.97) and has more now,
  // oldest first (result->fused_again; no new depth map). Low priority
  // work: the pipeline runs it only when no keyframe waits. False when none
  // qualifies.
  bool fuseAgain(KeyframeResult* result);

  // Loop closure: new camera-to-world pose of a stored keyframe; moves its map
  // points. False when the id is not (or no longer) stored. Throws InputError
  // for a bad pose.
  bool updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world);

  // Keyframes with a depth map that wait for fusion, oldest first.
  const std::vector<int64_t>& waitingForFusion() const { return schedule_.waiting(); }
  // Waiting keyframes evicted from the store before they were fused (since
  // construction or reset).
  size_t evictedBeforeFusion() const { return evicted_before_fusion_; }
  // Keyframes without a depth map that wait for source views, oldest first.
  const std::vector<int64_t>& waitingForSources() const { return waiting_for_sources_; }
  // Of those, the ones evicted from the store before they got a depth map.
  size_t evictedWithoutDepth() const { return evicted_without_depth_; }
  // With rolling_shutter.readout_s > 0: keyframes whose image was rectified,
  // and those used as they came (no keyframe within max_interval_s before
  // them to tell the motion; the first of a run is rectified with the
  // second's motion while nothing has read its image yet).
  size_t rollingShutterRectified() const { return rolling_shutter_.rectified(); }
  size_t rollingShutterNotRectified() const { return rolling_shutter_.notRectified(); }

  // Forgets every keyframe and empties the map.
  void reset();

  // Options that may change while running (dynamic reconfigure); the store
  // and map bounds stay. Throws InputError (nothing changes) when invalid.
  void setOptions(const OnlineMapperOptions& options);

  const KeyframeStore& store() const { return store_; }
  // The map, after any update in the background finished.
  const VoxelMap& map() const { return map_.map(); }
  // The surface map (null with surface.enabled off), after any update in the background.
  const TsdfMap* surface() const { return map_.surface(); }
  // Voxels after the last finished map update (does not wait).
  size_t mapVoxelCount() const { return map_.voxelCount(); }
  // Waits for a map update in the background (an exception it threw is
  // thrown here).
  void finishMapWork() const { map_.finish(); }
  // The map updates finished since the last call (or reset), in order.
  std::vector<MapUpdateRecord> takeMapUpdates() { return map_.takeUpdates(); }
  const OnlineMapperOptions& options() const { return options_; }
  // Incremented by every change of the map (add, re-pose, reset).
  uint64_t mapRevision() const { return map_.revision(); }

 private:
  // Steps 3-6 for a stored keyframe whose sources were selected; with
  // `defer_fusion` step 5 waits for the next call (process()).
  void estimateAndFuse(int64_t id, bool defer_fusion, KeyframeResult* result);
  // The estimate of a pending keyframe (its sources are protected in the
  // store); a deferred fusion runs meanwhile on this thread when the
  // store's room guarantees that it cannot evict them.
  DepthMap estimateWhileFusing(const DepthProblem& problem, KeyframeResult* result);
  // A deferred fusion's outcome into `result`: what an earlier call left
  // undelivered, then the fusion itself when it still waits.
  void runDeferredFusion(KeyframeResult* result);
  // Fused keyframes and evictions that an earlier failed call could not hand out.
  void handOutUndelivered(KeyframeResult* result);
  void keepUndelivered(KeyframeResult* result);
  // Runs a deferred fusion now; its outcome waits in undelivered_.
  void fuseDeferredNow();
  // estimateAndFuse() for an earlier keyframe (late: its first depth map;
  // else a refinement), into a fresh result.
  // `start`: when the call began (its selection is timed from there).
  void estimateStored(int64_t id, SourceSelection selection, bool late,
                      std::chrono::steady_clock::time_point start, KeyframeResult* result);
  // What the mapper keeps of a keyframe with a depth map besides the store's
  // entry and its fusion (schedule_): what it was estimated with, for
  // refine(). One record per keyframe, so that forgetting one is one erase.
  struct KeyframeRecord {
    std::vector<int64_t> sources;
    double score = 0;  // total selection score
    int refinements = 0;
    // The store's revision when refine() last chose its sources anew and kept
    // the estimate (an idle pipeline asks every step; nothing changed since).
    uint64_t selection_checked_at = kNeverChecked;
    static constexpr uint64_t kNeverChecked = ~uint64_t{0};
    // pose_refinement.keyframe_bundle_adjustment: each source's camera as
    // the estimate used it (reference at the tracker's pose), and how often
    // it was estimated again because the adjustment moved them since.
    std::map<int64_t, PinholeCamera> stereo_sources;
    PinholeCamera stereo_reference;
    int pose_reestimates = 0;
  };
  // True when the keyframe bundle adjustment has moved a source of the
  // record's estimate (relative to its reference) enough to change the depth.
  bool stereoPosesMoved(int64_t id, const KeyframeRecord& record) const;
  // Re-checks every waiting keyframe; fuses those with enough views.
  void fuseWaiting(KeyframeResult* result);
  // What the surface map takes of a fused keyframe (nothing when it is off).
  Shared<SurfaceDepth> surfaceDepth(int64_t id, const PublishedDepth& published) const;
  // Fuses keyframe `id` against `views` now (its points, confidence, map).
  void fuseNow(int64_t id, std::vector<int64_t> views, KeyframeResult* result);
  // Fuses an already fused keyframe again, as the result of this step.
  void fuseAgainNow(int64_t id, std::vector<int64_t> views, std::chrono::steady_clock::time_point start,
                    KeyframeResult* result);
  // refinement.fuse_neighbours_again: one keyframe fused against a depth
  // map that a refinement replaced since, fused again now, if any.
  bool fuseAgainstReplacedMaps(KeyframeResult* result);
  // Marks stored keyframe `id` done without depth (a source only).
  void markSourceOnly(int64_t id, KeyframeResult* result);
  // Drops a keyframe that left the store from every list and cache (not the map).
  struct Forgotten {
    bool was_waiting_for_sources = false;
    bool was_waiting_for_fusion = false;
  };
  Forgotten forgetKeyframe(int64_t id);
  // Records evictions in the result; drops evicted waiting keyframes.
  void noteEvicted(const std::vector<int64_t>& evicted, KeyframeResult* result);

  OnlineMapperOptions options_;
  std::unique_ptr<PoseRefiner> pose_refiner_;  // when options_.pose_refinement.enabled
  // What it found between keyframes (for stereo and fusion), and the map
  // poses corrected from it (correct_map_poses / keyframe_bundle_adjustment).
  MapPoseCorrection poses_;
  EstimateFunction estimate_;
  std::unique_ptr<SerialWorker> estimate_worker_;  // estimates that overlap a deferred fusion
  struct DeferredFusion {
    bool pending = false;  // step 5 of the last depth map waits (process(..., next_follows))
    int64_t id = 0;        // that depth map's keyframe
    // What a deferred fusion did during an estimate that then threw, or
    // ahead of a late estimate or refinement: handed out with the next
    // result (fused keyframes, evictions).
    KeyframeResult undelivered;
  };
  DeferredFusion deferred_;
  KeyframeStore store_;
  MapUpdater map_;  // the voxel and surface maps, updated in the background when map_in_background
  ConsistencyFusion consistency_;  // reads store_ and poses_
  FusionSchedule schedule_;
  TemporalDepth temporal_;  // step 8
  size_t evicted_before_fusion_ = 0;
  std::vector<int64_t> waiting_for_sources_;  // no source view yet; oldest first
  std::map<int64_t, KeyframeRecord> records_;  // keyframes with a depth map, by id
  // The centre of the keyframe added last (refine() checks near it first).
  Eigen::Vector3d newest_centre_ = Eigen::Vector3d::Zero();
  size_t evicted_without_depth_ = 0;
  // Rolling-shutter rectification of the stored images.
  RollingShutterRectifier rolling_shutter_;
  uint64_t estimates_started_ = 0;  // images are read once an estimate has started
};

}  // namespace amhmvs
