// The online mapping pipeline (ROS-free): keyframes in, depth maps, fused
// keyframe clouds and the global map out. The mapping nodelet, amhmvs_map
// (recorded sequences) and the GPU tests all drive this one class.
//
//   MappingPipeline pipeline(options, log);
//   pipeline.push(std::move(keyframe));       // any thread: bounded queue
//   pipeline.pushPoseUpdate(id, pose);        // any thread: loop closure
//   pipeline.observe(std::move(frame));       // any thread: a frame between keyframes (depth_filter)
//   for (const PipelineOutput& out : pipeline.step()) { ...publish / write... }
//   PipelineStats stats = pipeline.stats();   // any thread: typed counters
//
// It owns:
//   - a bounded input queue of keyframes: when full, the OLDEST waiting
//     keyframe is dropped (counted in stats, reported once per
//     options.report_period_s through the log, with what to change); once it
//     has overflowed the input is faster than the estimator, and the next
//     keyframe taken is the NEWEST: the older queued ones are dropped too
//     (skip_to_newest, counted), so that the map follows the camera instead
//     of working through a stale backlog; the newest max_sources of them
//     stay in the store as source views (no depth map of their own), so that
//     the newest keyframe still has near partners. A burst that fits the
//     queue (a short bag) is processed in order, every keyframe;
//   - the depth estimator with its CPU fallback (FallbackEstimator: a GPU
//     failure reruns the keyframe on the CPU; after switch_to_cpu_after
//     failures in a row every keyframe does);
//   - the mapping core (OnlineMapper: keyframe store, source selection, depth
//     range, deferred fusion, voxel map) and its scheduling.
//
// Scheduling of one step() (the nodelet's worker calls it in a loop, the
// offline tool until idle()):
//   1. pending work from other threads: options, reset, pose updates;
//   2. the oldest queued keyframe, if any (OnlineMapper::process); the
//      newest after an overflow (skip_to_newest). When another keyframe
//      waits behind it (and options.fusion_overlap allows), its fusion is
//      deferred to the next step and runs during that keyframe's estimate;
//      a deferred fusion whose next keyframe did not come (a reset, a
//      dropped keyframe) runs alone when the queue is empty;
//   3. one late depth map (a keyframe that had no source when it arrived and
//      has one now); then, when the queue is empty, the newest frame between
//      keyframes (observe(): it refines the newest keyframes' depth);
//   4. only when the queue is empty and 3 did no late depth map: one keyframe fused
//      again with more views (OnlineMapper::fuseAgain), else one refinement.
// New keyframes thus keep their rate; late work fills the gaps. Every output
// carries the keyframe's own id and stamp (late and refined results too).
//
// Threading: push(), pushPoseUpdate(), requestReset(), setOptions(),
// stats() and withMap() may be called from any thread; step() from one
// thread at a time (the worker).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "amhmvs_mapping/mapping/depth_map_fuser.h"
#include "amhmvs_mapping/mapping/fallback_estimator.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

// When a keyframe's fusion waits for the next keyframe's estimate and runs
// during it (OnlineMapper::process(..., next_follows)): only with a GPU
// estimator by default (the CPU gains nothing, its cores are the
// estimator's, and a deferred keyframe would be published one estimate
// later, seconds on the CPU).
enum class FusionOverlap { kOff, kGpu, kAlways };

struct PipelineOptions {
  OnlineMapperOptions mapper;
  // The paper's defaults. Real video gains from the coarse-to-fine aid
  // (multiscale_levels 2, multiscale_iterations 1: README "Real tracked
  // video"; on the GPU as fast as one scale since session 11); it is not the
  // default because exact cameras lose at the 1 % level with it (the
  // fountain bag's map 88.4 against 89.8 % within 1 % of the sparse points).
  PatchMatchOptions estimator;
  Backend backend = Backend::kAuto;      // kAuto: CUDA when a GPU is usable, else the CPU (logged)
  EstimatorResources resources;          // GPU: device-memory budget of resident keyframe images
  FuserResources fusion_resources;       // GPU: device-memory budget of resident depth maps (fusion)
  size_t queue_size = 4;                 // keyframes waiting for the estimator; >= 1
  bool skip_to_newest = true;            // after an overflow take the newest keyframe, drop the older queued ones
  int switch_to_cpu_after = 3;           // GPU failures in a row before every keyframe runs on the CPU
  bool late_depth_maps = true;           // step 3 of the scheduling
  // A keyframe followed by another in the queue is fused while the next
  // estimate runs (on the GPU they overlap: H100, 8 sources, 640x480: see
  // README "Speed"); its outputs come with the next step's.
  FusionOverlap fusion_overlap = FusionOverlap::kGpu;
  double report_period_s = 5.0;          // seconds between log lines of one kind of drop

  // Empty when valid; otherwise one line per problem, prefixed by the group.
  std::string validate() const;
};

// One result of step(): a new keyframe, a late depth map or a refinement.
struct PipelineOutput {
  KeyframeResult result;  // result.times: the stages, queue wait included
};

// Counters since construction (drops) or the last reset (the rest) (typed: the nodelet's
// diagnostics and amhmvs_map's summary list them with pipelineStatFields()).
struct PipelineStats {
  // Input.
  uint64_t keyframes_received = 0;     // push() calls that were accepted into the queue
  uint64_t dropped_queue_full = 0;     // oldest queued keyframes dropped for newer ones
  uint64_t dropped_skipped_for_newer = 0;  // queued keyframes skipped to the newest after an overflow (no depth map)
  uint64_t dropped_invalid = 0;        // keyframes the mapper refused (InputError)
  uint64_t dropped_backend_error = 0;  // keyframes whose estimate failed on every backend
  uint64_t dropped_processing_error = 0;  // any other exception while processing
  uint64_t late_estimate_failed = 0;
  uint64_t refinement_estimate_failed = 0;
  uint64_t fuse_again_failed = 0;      // fusions of an earlier keyframe with more views that threw
  uint64_t deferred_fusion_failed = 0;  // deferred fusions run alone (their next keyframe did not come) that threw
  uint64_t frames_refused = 0;          // frames between keyframes (observe()) the mapper refused (InputError)
  // Work done.
  uint64_t depth_maps = 0;             // first depth maps (late ones included)
  uint64_t late_depth_maps = 0;
  uint64_t refined_depth_maps = 0;     // refinements kept (better by the estimator's evidence)
  uint64_t refinements_rejected = 0;   // refinements worse than the depth map they would replace: dropped
  uint64_t pose_sources_refined = 0;   // pose refinement: sources whose relative pose was refined
  uint64_t pose_sources_rejected = 0;  // ... whose correction was implausible (the tracker's pose kept)
  uint64_t sources_aligned = 0;        // direct alignment: sources whose relative pose was aligned
  uint64_t keyframes_without_sources = 0;  // stored as a source only when they arrived
  uint64_t skipped_kept_as_sources = 0;    // skipped keyframes stored as source views of the newer ones
  uint64_t keyframes_fused = 0;
  uint64_t keyframes_fused_again = 0;
  // depth_filter: frames between keyframes (observe()) that refined the
  // newest keyframes' depth, those replaced by a newer one before the mapping
  // thread took them (it takes the newest), and the refined depths published.
  uint64_t frames_observed = 0;
  uint64_t frames_replaced = 0;
  uint64_t refined_depths = 0;
  uint64_t map_points_added = 0;
  uint64_t map_points_skipped_invalid = 0;
  uint64_t map_points_over_budget = 0;
  uint64_t map_points_outside_region = 0;
  // Keyframes whose points (map) or depth (surface) were released: they stay
  // in the maps but can no longer be moved (map/reposable_keyframes); re-fusions
  // of such a keyframe refused.
  uint64_t map_keyframes_frozen = 0;
  uint64_t surface_keyframes_frozen = 0;
  uint64_t map_refusions_refused_frozen = 0;
  uint64_t surface_blocks_dropped = 0;     // over surface/max_blocks
  uint64_t surface_blocks_pruned = 0;      // frozen, no voxel at surface/min_weight: erased
  uint64_t surface_keyframes_evicted = 0;  // removed from the surface map to make room
  uint64_t pose_updates_applied = 0;
  uint64_t pose_updates_not_stored = 0;  // evicted, reset, or not yet processed
  uint64_t bad_pose_updates = 0;
  uint64_t cpu_fallbacks = 0;          // keyframes rerun on the CPU after a GPU failure
  uint64_t fusion_cpu_fallbacks = 0;   // fusions redone on the CPU after a GPU failure
  uint64_t reconfigurations = 0;
  uint64_t bad_reconfigurations = 0;
  // State now.
  uint64_t queued = 0;
  uint64_t stored_keyframes = 0;
  uint64_t keyframes_evicted = 0;
  uint64_t keyframes_waiting_for_fusion = 0;
  uint64_t keyframes_evicted_before_fusion = 0;
  uint64_t keyframes_waiting_for_sources = 0;
  uint64_t keyframes_evicted_without_depth = 0;
  // mapper.rolling_shutter (since the last reset): images rectified, and
  // images used as they came (no keyframe close enough before to tell the motion).
  uint64_t rolling_shutter_rectified = 0;
  uint64_t rolling_shutter_not_rectified = 0;
  uint64_t map_voxels = 0;
  // As of the last map update: keyframe points kept for re-posing, surface
  // blocks, and both maps' heap memory.
  uint64_t map_points_kept = 0;
  uint64_t surface_blocks = 0;
  uint64_t map_memory_mib = 0;
  uint64_t map_revision = 0;
  bool idle = true;                    // the last step() found nothing to do and nothing is queued
  std::string backend = "not started"; // "cuda", "cpu", "cuda failed, now cpu"
  double last_estimate_ms = 0;
  double last_total_ms = 0;
  double last_map_update_ms = 0;       // the last voxel-map update (in the background when so configured)
  uint64_t gpu_memory_bytes = 0;       // device memory of the last estimate (CUDA)

  uint64_t droppedTotal() const {
    return dropped_queue_full + dropped_skipped_for_newer + dropped_invalid + dropped_backend_error +
           dropped_processing_error;
  }
};

// The integer counters of PipelineStats by name (diagnostics keys), in
// declaration order.
struct PipelineStatField {
  const char* name;
  uint64_t PipelineStats::*value;
};
const std::vector<PipelineStatField>& pipelineStatFields();

class MappingPipeline {
 public:
  enum class LogLevel { kDebug, kInfo, kWarn, kError };
  using Log = std::function<void(LogLevel, const std::string&)>;
  // The estimate a pipeline calls (tests inject failing or counting ones).
  using EstimatorFactory = std::function<EstimateFunction(Backend backend, const PatchMatchOptions&)>;

  // Creates the estimator (kAuto picks CUDA when usable; a CUDA backend that
  // cannot start falls back to the CPU, logged). Throws InputError when the
  // options are invalid.
  explicit MappingPipeline(const PipelineOptions& options, Log log = {});
  // The same with an injected primary estimator (tests); `fallback` may be empty.
  MappingPipeline(const PipelineOptions& options, EstimateFunction primary, EstimateFunction fallback,
                  std::string backend_name, Log log = {});
  ~MappingPipeline();
  MappingPipeline(const MappingPipeline&) = delete;
  MappingPipeline& operator=(const MappingPipeline&) = delete;

  // Queues a keyframe (any thread). Returns how many older queued keyframes
  // were dropped to make room (also counted and logged). Validation happens
  // in step() (a bad keyframe is dropped there, counted, logged).
  size_t push(Keyframe keyframe);
  // A frame between keyframes (any thread; it does nothing without
  // mapper.depth_filter.enabled): it refines the depth of the
  // newest keyframes when no keyframe waits. One waits at a time: a newer
  // one replaces it (counted: frames_replaced).
  void observe(Keyframe frame);
  // Loop closure (any thread): applied at the start of the next step().
  void pushPoseUpdate(int64_t id, const Eigen::Isometry3d& camera_to_world);
  // Forgets every queued and stored keyframe and the map at the start of the
  // next step(); the queue is cleared at once. Returns the keyframes discarded
  // from the queue. Counters of work and state restart
  // from zero at once; drop counters keep counting (lost input stays visible).
  size_t requestReset();
  // New mapper and estimator options, applied at the start of the next step()
  // (a new voxel size rebuilds the map). Invalid options are refused there
  // (counted in bad_reconfigurations, logged), the old ones stay.
  void setOptions(const OnlineMapperOptions& mapper, const PatchMatchOptions& estimator);

  // One round of work (see Scheduling); empty when there was nothing to do.
  std::vector<PipelineOutput> step();
  // Runs step() until nothing is queued and no late work is left (offline use).
  void runUntilIdle(const std::function<void(const PipelineOutput&)>& on_output);
  // Blocks until something is queued or pending, or `timeout_s` passed, or
  // wake() was called. True when there is work.
  bool waitForWork(double timeout_s);
  void wake();

  PipelineStats stats() const;
  // Read access to the mapper (map, store) under the pipeline's lock.
  void withMapper(const std::function<void(const OnlineMapper&)>& read) const;
  Backend backend() const;
  // The GPU estimator's resident keyframe images (zeros on the CPU).
  DeviceCacheStats deviceCacheStats() const;
  // Where fusion runs (kCuda when the estimator does and the fuser started)
  // and the fuser's resident depth maps.
  Backend fusionBackend() const { return fuser_ ? Backend::kCuda : Backend::kCpu; }
  FuserCacheStats fusionCacheStats() const;
  FuserTimes fusionTimes() const;  // the GPU fuser's time split (zeros on the CPU)
  const PipelineOptions& options() const { return options_; }

 private:
  struct Queued {
    Keyframe keyframe;
    double pushed_at = 0;  // steady clock, seconds
  };
  void init(EstimateFunction primary, EstimateFunction fallback, const std::string& backend_name);
  void applyPending();
  // The kinds of work of a step (what a failure of each counts as).
  enum class Work { kNewKeyframe, kDeferredFusion, kLate, kFuseAgain, kRefinement, kFrame };
  bool fusionOverlaps() const;
  // Runs one mapper call with error handling: false when it had nothing to
  // do, true when it worked or threw (counted and logged).
  bool run(Work work, int64_t id, const std::function<bool(KeyframeResult*)>& call,
           std::vector<PipelineOutput>* outputs, double queue_wait_ms);
  void account(const PipelineOutput& output);
  // The confidence and the published depth where fusion runs (GPU, CPU fallback counted as fusion's).
  PublishedDepth publish(const FusionView& reference, const std::vector<FusionView>& views,
                         const ConfidenceOptions& options, const ConfidenceCalibration& calibration);
  FusionResult fuse(const std::vector<FusionView>& views, const FusionOptions& options);
  // A call of the GPU fuser failed: logged and counted; the caller runs it on the CPU.
  void noteFusionCpuFallback(const std::string& message);
  // Drops the GPU copies (estimator images, fuser depth maps) of evicted keyframes.
  void forgetEvicted(const std::vector<int64_t>& evicted);
  // After a mapper call for keyframe `id`: records the fuser key of its depth
  // map; the key of a map it replaced is forgotten.
  void trackDepthKey(int64_t id);
  // After an estimate (on the estimate's thread): offers the GPU
  // estimator's outputs to the fuser when `map` is that estimate's (not the
  // CPU fallback's); the fuser takes the offer before its next call, on the
  // worker's thread (takeDeviceOffer), so that an estimate on another
  // thread never changes the fuser during a fusion.
  void offerDeviceOutputs(const DepthMap& map);
  void withdrawDeviceOffers(bool keep_last);
  void takeDeviceOffer();
  void report(LogLevel level, const std::string& kind, const std::string& line);
  // Why the input outruns the estimator, measured (keyframe interval, time
  // per keyframe), and what to change: the end of the overload log lines.
  std::string overloadAdvice() const;
  // Step 2's keyframe: the oldest queued, or after an overflow the newest
  // (the others dropped and counted; the newest max_sources of them, oldest
  // first, into `sources`). False when nothing is queued.
  bool takeNextKeyframe(Queued* next, std::vector<Keyframe>* sources);

  PipelineOptions options_;
  Log log_;
  Backend backend_ = Backend::kCpu;
  std::unique_ptr<DepthEstimator> estimator_, cpu_estimator_;
  std::unique_ptr<FallbackEstimator> fallback_;
  std::unique_ptr<DepthMapFuser> fuser_;  // fusion on the GPU when the estimator runs there
  // The estimate runs on the mapper's worker thread while a deferred fusion
  // runs (OnlineMapper::process(..., next_follows)): it offers its device
  // outputs from there; the fusion on the mapping thread takes them.
  std::mutex offer_mutex_;
  std::vector<DeviceDepthMap> offered_;   // the last estimates' device outputs (empty: a CPU estimate's)
  bool offer_new_ = false;                // not yet handed to the fuser
  // Keyframe id -> the fuser key of its depth map (FusionView::key, which is
  // not the keyframe id): a replaced (refined) map or an evicted keyframe's
  // leaves the device at once.
  std::map<int64_t, int64_t> fused_keys_;
  std::unique_ptr<OnlineMapper> mapper_;

  mutable std::mutex mapper_mutex_;  // mapper_, stats_ mapper-derived fields
  mutable std::mutex queue_mutex_;   // queue_ and pending work
  std::condition_variable queue_cv_;
  std::vector<Queued> queue_;        // oldest first
  std::unique_ptr<Keyframe> frame_;  // the newest frame between keyframes (observe())
  bool overflowed_ = false;          // the queue dropped a keyframe since the last skip to the newest
  double last_push_at_ = 0;          // steady seconds of the last push (0: none yet)
  double mean_push_interval_s_ = 0;  // running mean of the seconds between pushes
  std::map<int64_t, Eigen::Isometry3d> pose_updates_;
  std::unique_ptr<std::pair<OnlineMapperOptions, PatchMatchOptions>> pending_options_;
  bool reset_requested_ = false;
  bool woken_ = false;

  // stats() and the reports are called from the caller's threads (ROS
  // callbacks, diagnostics) while the mapping thread updates them.
  mutable std::mutex stats_mutex_;
  PipelineStats stats_;
  std::mutex report_mutex_;
  std::map<std::string, double> last_report_;  // kind -> steady seconds
};

}  // namespace amhmvs
