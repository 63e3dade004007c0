#include "amhmvs_mapping/mapping/mapping_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string keyframeName(int64_t id) { return "keyframe " + std::to_string(id); }

// What a reset keeps: the backend and the drop counts (lifetime: a reset
// does not hide lost input).
PipelineStats statsAfterReset(const PipelineStats& old) {
  PipelineStats fresh;
  fresh.backend = old.backend;
  fresh.dropped_queue_full = old.dropped_queue_full;
  fresh.dropped_skipped_for_newer = old.dropped_skipped_for_newer;
  fresh.dropped_invalid = old.dropped_invalid;
  fresh.dropped_backend_error = old.dropped_backend_error;
  fresh.dropped_processing_error = old.dropped_processing_error;
  fresh.late_estimate_failed = old.late_estimate_failed;
  fresh.refinement_estimate_failed = old.refinement_estimate_failed;
  fresh.fuse_again_failed = old.fuse_again_failed;
  fresh.deferred_fusion_failed = old.deferred_fusion_failed;
  fresh.frames_refused = old.frames_refused;
  fresh.bad_pose_updates = old.bad_pose_updates;
  fresh.bad_reconfigurations = old.bad_reconfigurations;
  return fresh;
}

}  // namespace

const std::vector<PipelineStatField>& pipelineStatFields() {
  // Names are the nodelet's diagnostics keys (README, rostests).
  static const std::vector<PipelineStatField> fields = {
      {"keyframes_received", &PipelineStats::keyframes_received},
      {"dropped: queue_full", &PipelineStats::dropped_queue_full},
      {"dropped: skipped_for_newer", &PipelineStats::dropped_skipped_for_newer},
      {"dropped: invalid_keyframe", &PipelineStats::dropped_invalid},
      {"dropped: backend_error", &PipelineStats::dropped_backend_error},
      {"dropped: processing_error", &PipelineStats::dropped_processing_error},
      {"late_estimate_failed", &PipelineStats::late_estimate_failed},
      {"refinement_estimate_failed", &PipelineStats::refinement_estimate_failed},
      {"fuse_again_failed", &PipelineStats::fuse_again_failed},
      {"deferred_fusion_failed", &PipelineStats::deferred_fusion_failed},
      {"depth_maps", &PipelineStats::depth_maps},
      {"late_depth_maps", &PipelineStats::late_depth_maps},
      {"refined_depth_maps", &PipelineStats::refined_depth_maps},
      {"refinements_rejected", &PipelineStats::refinements_rejected},
      {"pose_sources_refined", &PipelineStats::pose_sources_refined},
      {"pose_sources_rejected", &PipelineStats::pose_sources_rejected},
      {"sources_aligned", &PipelineStats::sources_aligned},
      {"keyframes_without_sources", &PipelineStats::keyframes_without_sources},
      {"skipped_kept_as_sources", &PipelineStats::skipped_kept_as_sources},
      {"keyframes_fused", &PipelineStats::keyframes_fused},
      {"keyframes_fused_again", &PipelineStats::keyframes_fused_again},
      {"frames_observed", &PipelineStats::frames_observed},
      {"frames_replaced", &PipelineStats::frames_replaced},
      {"refined_depths", &PipelineStats::refined_depths},
      {"frames_refused", &PipelineStats::frames_refused},
      {"map_points_added", &PipelineStats::map_points_added},
      {"map_points_skipped_invalid", &PipelineStats::map_points_skipped_invalid},
      {"map_points_over_budget", &PipelineStats::map_points_over_budget},
      {"map_points_outside_region", &PipelineStats::map_points_outside_region},
      {"pose_updates_applied", &PipelineStats::pose_updates_applied},
      {"pose_updates_not_stored", &PipelineStats::pose_updates_not_stored},
      {"pose_updates_refused", &PipelineStats::bad_pose_updates},
      {"cpu_fallbacks", &PipelineStats::cpu_fallbacks},
      {"fusion_cpu_fallbacks", &PipelineStats::fusion_cpu_fallbacks},
      {"reconfigurations", &PipelineStats::reconfigurations},
      {"reconfigurations_refused", &PipelineStats::bad_reconfigurations},
      {"queued", &PipelineStats::queued},
      {"stored_keyframes", &PipelineStats::stored_keyframes},
      {"keyframes_evicted", &PipelineStats::keyframes_evicted},
      {"keyframes_waiting_for_fusion", &PipelineStats::keyframes_waiting_for_fusion},
      {"keyframes_evicted_before_fusion", &PipelineStats::keyframes_evicted_before_fusion},
      {"keyframes_waiting_for_sources", &PipelineStats::keyframes_waiting_for_sources},
      {"keyframes_evicted_without_depth", &PipelineStats::keyframes_evicted_without_depth},
      {"rolling_shutter_rectified", &PipelineStats::rolling_shutter_rectified},
      {"rolling_shutter_not_rectified", &PipelineStats::rolling_shutter_not_rectified},
      {"map voxels", &PipelineStats::map_voxels},
      {"map_keyframes_frozen", &PipelineStats::map_keyframes_frozen},
      {"surface_keyframes_frozen", &PipelineStats::surface_keyframes_frozen},
      {"map_refusions_refused_frozen", &PipelineStats::map_refusions_refused_frozen},
      {"surface_blocks_dropped", &PipelineStats::surface_blocks_dropped},
      {"surface_blocks_pruned", &PipelineStats::surface_blocks_pruned},
      {"surface_keyframes_evicted", &PipelineStats::surface_keyframes_evicted},
      {"map_points_kept", &PipelineStats::map_points_kept},
      {"surface_blocks", &PipelineStats::surface_blocks},
      {"map_memory_mib", &PipelineStats::map_memory_mib},
  };
  return fields;
}

std::string PipelineOptions::validate() const {
  std::ostringstream out;
  const std::string mapper_problems = mapper.validate();
  if (!mapper_problems.empty()) out << mapper_problems;
  appendProblems("estimator", estimator.validate(), &out);
  if (queue_size < 1) out << "queue_size must be >= 1 (got " << queue_size << ")\n";
  if (switch_to_cpu_after < 1) out << "switch_to_cpu_after must be >= 1 (got " << switch_to_cpu_after << ")\n";
  if (!(report_period_s >= 0)) out << "report_period_s must be >= 0 (got " << report_period_s << ")\n";
  return out.str();
}

MappingPipeline::MappingPipeline(const PipelineOptions& options, Log log) : options_(options), log_(std::move(log)) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("mapping pipeline options:\n" + problems);
  std::string no_gpu;
  const Backend backend = resolvedBackend(options.backend, &no_gpu);
  if (options.backend == Backend::kAuto && backend == Backend::kCpu)
    report(LogLevel::kWarn, "backend",
           no_gpu + ", using the CPU: it needs a small max_image_size (e.g. 256..320) for online rates");
  try {
    estimator_.reset(new DepthEstimator(options.estimator, backend, options.resources));
  } catch (const BackendError& e) {
    report(LogLevel::kError, "backend", std::string(backendName(backend)) + " backend failed (" + e.what() +
                                            "), using the CPU");
    estimator_.reset(new DepthEstimator(options.estimator, Backend::kCpu));
  }
  backend_ = estimator_->backend();
  report(LogLevel::kInfo, "backend", std::string("depth estimation backend: ") + backendName(backend_));
  if (backend_ == Backend::kCuda) {
    try {
      fuser_.reset(new DepthMapFuser(Backend::kCuda, options.fusion_resources));
    } catch (const BackendError& e) {
      report(LogLevel::kError, "backend", std::string("fusion on the GPU failed (") + e.what() + "), fusing on the CPU");
    }
  }
  EstimateFunction fallback;
  if (backend_ != Backend::kCpu) {
    // Made now, not at the first failure: forgetEvicted() tells it too (its
    // coarser image copies), from another thread than the estimate's.
    cpu_estimator_.reset(new DepthEstimator(options_.estimator, Backend::kCpu));
    fallback = [this](const DepthProblem& problem) { return cpu_estimator_->estimate(problem); };
  }
  init([this](const DepthProblem& problem) { return estimator_->estimate(problem); }, fallback,
       backendName(backend_));
}

MappingPipeline::MappingPipeline(const PipelineOptions& options, EstimateFunction primary, EstimateFunction fallback,
                                 std::string backend_name, Log log)
    : options_(options), log_(std::move(log)) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("mapping pipeline options:\n" + problems);
  init(std::move(primary), std::move(fallback), backend_name);
}

MappingPipeline::~MappingPipeline() = default;

void MappingPipeline::init(EstimateFunction primary, EstimateFunction fallback, const std::string& backend_name) {
  stats_.backend = backend_name;
  // A failing GPU: the keyframe reruns on the CPU; after switch_to_cpu_after
  // failures in a row every keyframe does. The CPU has no fallback.
  fallback_.reset(new FallbackEstimator(std::move(primary), std::move(fallback), options_.switch_to_cpu_after,
                                        [this, backend_name](const std::string& line) {
                                          report(LogLevel::kError, "fallback", backend_name + " backend: " + line);
                                          std::lock_guard<std::mutex> lock(stats_mutex_);
                                          ++stats_.cpu_fallbacks;
                                        }));
  const std::string name = backend_name;
  const auto estimate = [this, name](const DepthProblem& problem) {
    DepthMap map = (*fallback_)(problem);
    if (fallback_->switched()) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      stats_.backend = name + " failed, now cpu";
    }
    offerDeviceOutputs(map);
    return map;  // moved: its images keep the addresses the fuser was offered
  };
  const auto fuse = [this](const std::vector<FusionView>& views, const FusionOptions& options) {
    return this->fuse(views, options);
  };
  const auto publish = [this](const FusionView& reference, const std::vector<FusionView>& views,
                              const ConfidenceOptions& confidence, const ConfidenceCalibration& calibration) {
    return this->publish(reference, views, confidence, calibration);
  };
  options_.mapper.depth_filter.on_gpu = backend_ == Backend::kCuda;
  options_.mapper.neighbour_depth.on_gpu = backend_ == Backend::kCuda;
  mapper_.reset(new OnlineMapper(options_.mapper, estimate, fuse, publish));
  if (options_.mapper.pose_refinement.enabled && !PoseRefiner::available())
    report(LogLevel::kWarn, "pose_refinement", std::string(PoseRefiner::unavailableMessage()) +
                                                   ": the sources' poses are the tracker's, unrefined");
}

void MappingPipeline::forgetEvicted(const std::vector<int64_t>& evicted) {
  // Keyframe ids are the estimator's image keys: an evicted keyframe's image
  // and depth map leave the GPU too.
  for (int64_t id : evicted) {
    if (estimator_) estimator_->forget(id);
    if (cpu_estimator_) cpu_estimator_->forget(id);
    const auto fused = fused_keys_.find(id);
    if (fused != fused_keys_.end()) {
      fuser_->forget(fused->second);
      fused_keys_.erase(fused);
    }
  }
}

void MappingPipeline::offerDeviceOutputs(const DepthMap& map) {
  if (!fuser_ || !estimator_) return;
  // Fusion copies this map on the GPU instead of uploading it, when the GPU
  // estimator made it (not the CPU fallback).
  const DeviceDepthMap outputs = estimator_->lastDeviceOutputs();
  std::lock_guard<std::mutex> lock(offer_mutex_);
  offered_.push_back(outputs.host_depth == map.depth.data.data() ? outputs : DeviceDepthMap());
  offer_new_ = true;
}

void MappingPipeline::withdrawDeviceOffers(bool keep_last) {
  std::lock_guard<std::mutex> lock(offer_mutex_);
  if (keep_last && !offered_.empty()) {
    offered_.erase(offered_.begin(), offered_.end() - 1);
  } else {
    offered_.clear();
  }
  offer_new_ = true;
}

void MappingPipeline::takeDeviceOffer() {
  std::lock_guard<std::mutex> lock(offer_mutex_);
  if (!offer_new_) return;
  fuser_->setDeviceSources(offered_);
  offer_new_ = false;
}

bool MappingPipeline::fusionOverlaps() const {
  return options_.fusion_overlap == FusionOverlap::kAlways ||
         (options_.fusion_overlap == FusionOverlap::kGpu && backend_ == Backend::kCuda);
}

void MappingPipeline::trackDepthKey(int64_t id) {
  if (!fuser_ || !mapper_->store().contains(id)) return;
  // The store's depth revision is the fuser's key of the keyframe's map
  // (FusionView::key): a replaced map leaves the GPU now.
  const int64_t key = static_cast<int64_t>(mapper_->store().entry(id).depth_revision);
  const auto known = fused_keys_.emplace(id, key);
  if (known.second || known.first->second == key) return;
  fuser_->forget(known.first->second);
  known.first->second = key;
}

FusionResult MappingPipeline::fuse(const std::vector<FusionView>& views, const FusionOptions& options) {
  if (fuser_) {
    try {
      takeDeviceOffer();
      return fuser_->fuse(views, options);
    } catch (const BackendError& e) {
      noteFusionCpuFallback(std::string("fusion on the GPU failed (") + e.what() +
                            "), this keyframe is fused on the CPU");
    }
  }
  return fuseDepthMaps(views, options);
}

void MappingPipeline::noteFusionCpuFallback(const std::string& message) {
  report(LogLevel::kError, "fusion", message);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.fusion_cpu_fallbacks;
}

PublishedDepth MappingPipeline::publish(const FusionView& reference, const std::vector<FusionView>& views,
                                       const ConfidenceOptions& options, const ConfidenceCalibration& calibration) {
  if (fuser_) {
    try {
      takeDeviceOffer();
      return fuser_->publishDepth(reference, views, options, calibration);
    } catch (const BackendError& e) {
      noteFusionCpuFallback(std::string("confidence on the GPU failed (") + e.what() +
                            "), this keyframe's is computed on the CPU");
    }
  }
  return publishDepth(reference, views, options, calibration);
}

void MappingPipeline::report(LogLevel level, const std::string& kind, const std::string& line) {
  if (!log_) return;
  if ((level == LogLevel::kWarn || level == LogLevel::kError) && options_.report_period_s > 0) {
    // Throttled per kind, so that a flood of one problem stays readable.
    std::lock_guard<std::mutex> lock(report_mutex_);
    const double now = steadySeconds();
    const auto last = last_report_.find(kind);
    if (last != last_report_.end() && now - last->second < options_.report_period_s) return;
    last_report_[kind] = now;
  }
  log_(level, line);
}

size_t MappingPipeline::push(Keyframe keyframe) {
  size_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    while (queue_.size() >= options_.queue_size) {
      queue_.erase(queue_.begin());
      ++dropped;
    }
    if (dropped > 0) overflowed_ = true;
    const double now = steadySeconds();
    if (last_push_at_ > 0) {
      // Running mean over about the last 10 pushes: the input's keyframe interval.
      const double interval = now - last_push_at_;
      mean_push_interval_s_ = mean_push_interval_s_ > 0 ? 0.9 * mean_push_interval_s_ + 0.1 * interval : interval;
    }
    last_push_at_ = now;
    queue_.push_back({std::move(keyframe), now});
  }
  uint64_t total = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.keyframes_received;
    total = stats_.dropped_queue_full += dropped;
    stats_.idle = false;
  }
  queue_cv_.notify_all();
  if (dropped > 0) {
    report(LogLevel::kWarn, "queue_full",
           "input queue full (" + std::to_string(options_.queue_size) + " keyframes): dropped the oldest, " +
               std::to_string(total) + " dropped so far; " + overloadAdvice());
  }
  return dropped;
}

void MappingPipeline::observe(Keyframe frame) {
  bool replaced = false;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    replaced = frame_ != nullptr;
    frame_.reset(new Keyframe(std::move(frame)));
  }
  if (replaced) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.frames_replaced;
  }
  queue_cv_.notify_all();
}

std::string MappingPipeline::overloadAdvice() const {
  double interval_s;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    interval_s = mean_push_interval_s_;
  }
  double keyframe_s;
  std::string backend;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    keyframe_s = stats_.last_total_ms / 1000;
    backend = stats_.backend;
  }
  std::ostringstream out;
  out.precision(2);
  out << "estimation is slower than the keyframe rate";
  if (interval_s > 0 && keyframe_s > 0) {
    out << " (a keyframe arrives every " << interval_s << " s, one takes " << keyframe_s << " s on " << backend
        << ": about 1 in " << std::max(1.0, std::ceil(keyframe_s / interval_s)) << " can be mapped)";
  }
  out << ": lower max_image_size or estimator iterations, raise the keyframe distance "
         "(keyframe_min_translation / keyframe_min_rotation_deg), or use the GPU";
  return out.str();
}

bool MappingPipeline::takeNextKeyframe(Queued* next, std::vector<Keyframe>* sources) {
  size_t skipped = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (queue_.empty()) return false;
    if (options_.skip_to_newest && overflowed_) {
      skipped = queue_.size() - 1;
      const size_t kept = std::min<size_t>(skipped, static_cast<size_t>(options_.mapper.sources.max_sources));
      for (auto it = queue_.end() - 1 - kept; it != queue_.end() - 1; ++it) sources->push_back(std::move(it->keyframe));
      queue_.erase(queue_.begin(), queue_.end() - 1);
    }
    overflowed_ = false;
    *next = std::move(queue_.front());
    queue_.erase(queue_.begin());
  }
  if (skipped == 0) return true;
  uint64_t total;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    total = stats_.dropped_skipped_for_newer += skipped;
  }
  report(LogLevel::kWarn, "skipped_for_newer",
         "input outran the estimator: skipped " + std::to_string(skipped) + " queued keyframes to the newest (" +
             keyframeName(next->keyframe.id) + "; the last " + std::to_string(sources->size()) +
             " stay as its source views), " + std::to_string(total) + " skipped so far; " + overloadAdvice());
  return true;
}

void MappingPipeline::pushPoseUpdate(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    pose_updates_[id] = camera_to_world;
  }
  queue_cv_.notify_all();
}

size_t MappingPipeline::requestReset() {
  size_t discarded;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    discarded = queue_.size();
    queue_.clear();
    frame_.reset();
    overflowed_ = false;
    pose_updates_.clear();
    reset_requested_ = true;
  }
  {
    // Counters restart at once (diagnostics show the reset immediately); the
    // worker forgets the keyframes and the map at its next step.
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_ = statsAfterReset(stats_);
  }
  queue_cv_.notify_all();
  return discarded;
}

void MappingPipeline::setOptions(const OnlineMapperOptions& mapper, const PatchMatchOptions& estimator) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    pending_options_.reset(new std::pair<OnlineMapperOptions, PatchMatchOptions>(mapper, estimator));
  }
  queue_cv_.notify_all();
}

bool MappingPipeline::waitForWork(double timeout_s) {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  const auto pending = [this] {
    return woken_ || !queue_.empty() || frame_ || !pose_updates_.empty() || pending_options_ || reset_requested_;
  };
  queue_cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), pending);
  const bool work = !queue_.empty() || frame_ || !pose_updates_.empty() || pending_options_ || reset_requested_;
  woken_ = false;
  return work;
}

void MappingPipeline::wake() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    woken_ = true;
  }
  queue_cv_.notify_all();
}

void MappingPipeline::applyPending() {
  std::map<int64_t, Eigen::Isometry3d> updates;
  std::unique_ptr<std::pair<OnlineMapperOptions, PatchMatchOptions>> next;
  bool reset = false;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    updates.swap(pose_updates_);
    next.swap(pending_options_);
    std::swap(reset, reset_requested_);
  }
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  if (reset) {
    mapper_->reset();
    if (estimator_) estimator_->forgetAll();  // keyframe ids may be reused
    if (cpu_estimator_) cpu_estimator_->forgetAll();
    if (fuser_) fuser_->forgetAll();
    fused_keys_.clear();
    std::lock_guard<std::mutex> stats(stats_mutex_);
    stats_ = statsAfterReset(stats_);
  }
  if (next) {
    try {
      const std::string problems = next->second.validate();
      if (!problems.empty()) throw InputError("estimator options:\n" + problems);
      next->first.depth_filter.on_gpu = backend_ == Backend::kCuda;
      next->first.neighbour_depth.on_gpu = backend_ == Backend::kCuda;
      mapper_->setOptions(next->first);  // a new voxel size rebuilds the map
      if (estimator_) {  // an injected estimator (tests) stays as it is
        withdrawDeviceOffers(/*keep_last=*/false);  // the old estimator's buffers go with it
        estimator_.reset(new DepthEstimator(next->second, estimator_->backend(), options_.resources));
        if (cpu_estimator_) cpu_estimator_.reset(new DepthEstimator(next->second, Backend::kCpu));
      }
      options_.mapper = mapper_->options();
      options_.estimator = next->second;
      std::lock_guard<std::mutex> stats(stats_mutex_);
      ++stats_.reconfigurations;
    } catch (const std::exception& e) {
      {
        std::lock_guard<std::mutex> stats(stats_mutex_);
        ++stats_.bad_reconfigurations;
      }
      report(LogLevel::kError, "reconfiguration", std::string("new options refused, the old ones stay: ") + e.what());
    }
  }
  uint64_t applied = 0, not_stored = 0, refused = 0;
  for (const auto& update : updates) {
    try {
      if (mapper_->updatePose(update.first, update.second))
        ++applied;
      else
        ++not_stored;  // evicted, reset, or not yet processed
    } catch (const InputError& e) {
      ++refused;
      report(LogLevel::kError, "pose_update", e.what());
    }
  }
  std::lock_guard<std::mutex> stats(stats_mutex_);
  stats_.pose_updates_applied += applied;
  stats_.pose_updates_not_stored += not_stored;
  stats_.bad_pose_updates += refused;
}

bool MappingPipeline::run(Work work, int64_t id, const std::function<bool(KeyframeResult*)>& call,
                          std::vector<PipelineOutput>* outputs, double queue_wait_ms) {
  PipelineOutput output;
  output.result.id = id;
  const bool is_new = work == Work::kNewKeyframe;
  const std::string what = work == Work::kNewKeyframe      ? "keyframe"
                           : work == Work::kDeferredFusion ? "deferred fusion"
                           : work == Work::kLate           ? "late"
                           : work == Work::kFuseAgain      ? "fusion again"
                           : work == Work::kFrame          ? "frame"
                                                           : "refinement";
  uint64_t PipelineStats::*failure = nullptr;
  std::string reason;
  try {
    if (!call(&output.result)) return false;
  } catch (const InputError& e) {
    failure = is_new ? &PipelineStats::dropped_invalid : nullptr;
    reason = e.what();
  } catch (const BackendError& e) {
    failure = is_new ? &PipelineStats::dropped_backend_error : nullptr;
    reason = e.what();
  } catch (const std::exception& e) {
    failure = is_new ? &PipelineStats::dropped_processing_error : nullptr;
    reason = e.what();
  }
  // The estimator writes two sets of outputs in turn: the last estimate's
  // stay valid during the next one (the fusion of a deferred keyframe reads
  // them), the one's before are overwritten by it.
  withdrawDeviceOffers(/*keep_last=*/true);
  // Also after a failure: the depth map may have been attached (and fused
  // on the GPU) before something else threw.
  trackDepthKey(output.result.id);
  if (!reason.empty()) {
    // A new keyframe is dropped; a late one stays a source only; a refined
    // one keeps its depth map.
    if (!failure)
      failure = work == Work::kLate             ? &PipelineStats::late_estimate_failed
                : work == Work::kFuseAgain      ? &PipelineStats::fuse_again_failed
                : work == Work::kDeferredFusion ? &PipelineStats::deferred_fusion_failed
                : work == Work::kFrame          ? &PipelineStats::frames_refused
                                                : &PipelineStats::refinement_estimate_failed;
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++(stats_.*failure);
    }
    const bool fusion_only = work == Work::kFuseAgain || work == Work::kDeferredFusion;
    report(LogLevel::kError, what,
           (is_new        ? "dropped " + keyframeName(output.result.id)
            : fusion_only ? what + " of " + keyframeName(output.result.id) + " failed"
                          : what + " depth map of " + keyframeName(output.result.id) + " failed") +
               ": " + reason);
    return true;  // work was attempted
  }
  if (output.result.refinement_rejected) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.refinements_rejected;
    }
    report(LogLevel::kInfo, "refinement",
           "refinement of " + keyframeName(output.result.id) + " rejected, it keeps its depth map (" +
               output.result.refinement_evidence + ")");
    return true;  // nothing new to publish
  }
  output.result.times.queue_wait_ms = queue_wait_ms;
  forgetEvicted(output.result.evicted);
  account(output);
  outputs->push_back(std::move(output));
  return true;
}

void MappingPipeline::account(const PipelineOutput& output) {
  const KeyframeResult& result = output.result;
  // Fusions (again, or deferred) have no depth map either.
  const bool source_only = !result.has_depth && !result.fused_again && !result.deferred_fusion;
  if (source_only) {
    // One short line; why each stored keyframe was refused can run to kilobytes.
    report(LogLevel::kInfo, "no_sources",
           keyframeName(result.id) + ": no source view yet: stored as a source; its depth map follows once later "
                                     "keyframes qualify");
    report(LogLevel::kDebug, "no_sources", keyframeName(result.id) + " has no source view: " + result.selection.reason);
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (source_only) {
    ++stats_.keyframes_without_sources;
  } else if (result.has_depth) {
    if (!result.refined) ++stats_.depth_maps;
    if (result.late) ++stats_.late_depth_maps;
    if (result.refined) ++stats_.refined_depth_maps;
    stats_.pose_sources_refined += result.pose_refinement.refinedCount();
    stats_.pose_sources_rejected += result.pose_refinement.rejectedCount();
    stats_.sources_aligned += result.direct_alignment.alignedCount();
    stats_.last_estimate_ms = result.depth->milliseconds;
    stats_.gpu_memory_bytes = result.depth->gpu_memory_bytes;
  }
  stats_.last_total_ms = result.times.total_ms;
  for (const FusedKeyframe& fused : result.fused) ++(fused.again ? stats_.keyframes_fused_again : stats_.keyframes_fused);
  stats_.refined_depths += result.refined_depths.size();
  if (result.frame_only && options_.mapper.depth_filter.enabled) ++stats_.frames_observed;
}

std::vector<PipelineOutput> MappingPipeline::step() {
  applyPending();
  std::vector<PipelineOutput> outputs;
  Queued next;
  std::vector<Keyframe> skipped_sources;
  const bool have_keyframe = takeNextKeyframe(&next, &skipped_sources);
  bool worked = false;
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  for (Keyframe& source : skipped_sources) {
    const int64_t id = source.id;
    try {
      forgetEvicted(mapper_->addSourceView(std::move(source)));
      std::lock_guard<std::mutex> stats(stats_mutex_);
      ++stats_.skipped_kept_as_sources;
    } catch (const InputError& e) {
      report(LogLevel::kError, "keyframe", "skipped " + keyframeName(id) + " not kept as a source: " + e.what());
    }
  }
  const auto queueEmpty = [this] {
    std::lock_guard<std::mutex> queue_lock(queue_mutex_);
    return queue_.empty();
  };
  const auto takeFrame = [this] {
    std::lock_guard<std::mutex> queue_lock(queue_mutex_);
    return std::move(frame_);
  };
  if (have_keyframe) {
    const double wait_ms = 1000 * (steadySeconds() - next.pushed_at);
    const int64_t id = next.keyframe.id;
    // The next keyframe waits already: this one is fused during its estimate.
    const bool next_follows = fusionOverlaps() && !queueEmpty();
    worked |= run(Work::kNewKeyframe, id,
                  [&](KeyframeResult* result) {
                    *result = mapper_->process(std::move(next.keyframe), next_follows);
                    return true;
                  },
                  &outputs, wait_ms);
  }
  bool queue_empty = queueEmpty();
  if (queue_empty && mapper_->fusionDeferred()) {
    worked |= run(Work::kDeferredFusion, -1, [&](KeyframeResult* result) { return mapper_->fuseDeferred(result); },
                  &outputs, 0);
  }
  // At most one late depth map per step; refinements only when no keyframe
  // waits and nothing else was late: new keyframes keep their rate.
  bool late_work = false;
  if (options_.late_depth_maps)
    late_work = run(Work::kLate, -1, [&](KeyframeResult* result) { return mapper_->estimateLate(result); }, &outputs, 0);
  queue_empty = queueEmpty();
  // A frame is worth most while it is new: before the idle work.
  if (queue_empty) {
    if (std::unique_ptr<Keyframe> frame = takeFrame()) {
      worked |= run(Work::kFrame, -1,
                    [&](KeyframeResult* result) {
                      result->frame_only = true;
                      result->refined_depths = mapper_->observe(*frame);
                      return true;
                    },
                    &outputs, 0);
    }
  }
  if (!late_work && queue_empty)
    late_work = run(Work::kFuseAgain, -1, [&](KeyframeResult* result) { return mapper_->fuseAgain(result); }, &outputs, 0);
  if (!late_work && queue_empty)
    late_work = run(Work::kRefinement, -1, [&](KeyframeResult* result) { return mapper_->refine(result); }, &outputs, 0);
  worked |= late_work;

  // The map update of this step's fusion runs in the background while the
  // next keyframe is estimated; with no keyframe waiting it is finished now,
  // so that an idle pipeline's map and statistics are complete.
  if (queueEmpty()) {
    try {
      mapper_->finishMapWork();
    } catch (const std::exception& e) {
      report(LogLevel::kError, "map", std::string("map update failed: ") + e.what());
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.dropped_processing_error;
    }
  }
  const std::vector<MapUpdateRecord> map_updates = mapper_->takeMapUpdates();

  std::lock_guard<std::mutex> stats(stats_mutex_);
  for (const MapUpdateRecord& record : map_updates) {
    stats_.map_points_added += record.update.added_points;
    stats_.map_points_skipped_invalid += record.update.skipped_invalid;
    stats_.map_points_over_budget += record.update.dropped_over_budget;
    stats_.map_points_outside_region += record.update.outside_region;
    stats_.last_map_update_ms = record.milliseconds;
    stats_.map_keyframes_frozen += record.update.frozen_keyframes.size();
    stats_.surface_keyframes_frozen += record.surface.frozen_keyframes.size();
    stats_.map_refusions_refused_frozen += record.update.refused_frozen;
    stats_.surface_blocks_dropped += record.surface.dropped_blocks;
    stats_.surface_blocks_pruned += record.surface.pruned_blocks;
    stats_.surface_keyframes_evicted += record.surface.evicted_keyframes.size();
    stats_.map_points_kept = record.kept_points;
    stats_.surface_blocks = record.surface_blocks;
    stats_.map_memory_mib = record.memory_bytes >> 20;
  }
  stats_.stored_keyframes = mapper_->store().size();
  stats_.keyframes_evicted = mapper_->store().evictedCount();
  stats_.keyframes_waiting_for_fusion = mapper_->waitingForFusion().size();
  stats_.keyframes_evicted_before_fusion = mapper_->evictedBeforeFusion();
  stats_.keyframes_waiting_for_sources = mapper_->waitingForSources().size();
  stats_.keyframes_evicted_without_depth = mapper_->evictedWithoutDepth();
  stats_.rolling_shutter_rectified = mapper_->rollingShutterRectified();
  stats_.rolling_shutter_not_rectified = mapper_->rollingShutterNotRectified();
  stats_.map_voxels = mapper_->mapVoxelCount();
  stats_.map_revision = mapper_->mapRevision();
  {
    std::lock_guard<std::mutex> queue_lock(queue_mutex_);
    // Idle: nothing was done and nothing waits (every output of the input so far is out).
    stats_.idle = !worked && queue_.empty() && !frame_;
  }
  return outputs;
}

void MappingPipeline::runUntilIdle(const std::function<void(const PipelineOutput&)>& on_output) {
  while (true) {
    const std::vector<PipelineOutput> outputs = step();
    for (const PipelineOutput& output : outputs)
      if (on_output) on_output(output);
    if (stats().idle) return;
  }
}

PipelineStats MappingPipeline::stats() const {
  PipelineStats copy;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    copy = stats_;
  }
  std::lock_guard<std::mutex> lock(queue_mutex_);
  copy.queued = queue_.size();
  return copy;
}

void MappingPipeline::withMapper(const std::function<void(const OnlineMapper&)>& read) const {
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  read(*mapper_);
}

Backend MappingPipeline::backend() const { return backend_; }

DeviceCacheStats MappingPipeline::deviceCacheStats() const {
  std::lock_guard<std::mutex> lock(mapper_mutex_);  // estimator_ is replaced under it
  return estimator_ ? estimator_->deviceCacheStats() : DeviceCacheStats();
}

FuserCacheStats MappingPipeline::fusionCacheStats() const {
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  return fuser_ ? fuser_->cacheStats() : FuserCacheStats();
}

FuserTimes MappingPipeline::fusionTimes() const {
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  return fuser_ ? fuser_->times() : FuserTimes();
}

}  // namespace amhmvs
