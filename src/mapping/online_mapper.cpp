#include "amhmvs_mapping/mapping/online_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/stopwatch.h"
#include "amhmvs_mapping/mapping/map_export.h"
#include "amhmvs_mapping/mapping/refinement_evidence.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs {
namespace {

using Clock = std::chrono::steady_clock;

ConsistencyFusionOptions consistencyFusionOptions(const OnlineMapperOptions& options) {
  ConsistencyFusionOptions fusion;
  fusion.sources = options.sources;
  fusion.fusion = options.fusion;
  fusion.confidence = options.confidence;
  fusion.at_refined_poses = options.pose_refinement.enabled && options.pose_refinement.in_fusion;
  return fusion;
}

// Total score of the selected sources (they come first among the candidates).
double selectionScore(const SourceSelection& selection) {
  double score = 0;
  for (size_t i = 0; i < selection.source_ids.size() && i < selection.candidates.size(); ++i)
    score += selection.candidates[i].score;
  return score;
}

}  // namespace

FusionOptions onlineFusionOptions() {
  FusionOptions options = FusionOptions::reprojection();
  options.max_relative_depth_difference = 0.02f;
  return options;
}

void appendProblems(const std::string& group, const std::string& problems, std::ostringstream* out) {
  std::istringstream lines(problems);
  for (std::string line; std::getline(lines, line);)
    if (!line.empty()) *out << group << ": " << line << "\n";
}

std::string RefinementOptions::validate() const {
  std::ostringstream why;
  if (max_refinements < 0) why << "max_refinements must be >= 0 (got " << max_refinements << ")\n";
  if (!(std::isfinite(min_score_gain) && min_score_gain > 1))
    why << "min_score_gain must be finite and > 1 (got " << min_score_gain << ")\n";
  if (!(confident_cost >= 0)) why << "confident_cost must be >= 0 (got " << confident_cost << ")\n";
  if (!(max_confident_loss >= 0 && max_confident_loss < 1))
    why << "max_confident_loss must be in [0, 1) (got " << max_confident_loss << ")\n";
  return why.str();
}

std::string OnlineMapperOptions::validate() const {
  std::ostringstream out;
  appendProblems("store", store.validate(), &out);
  appendProblems("sources", sources.validate(), &out);
  appendProblems("depth_range", depth_range.validate(), &out);
  appendProblems("fusion", fusion.validate(), &out);
  appendProblems("map", map.validate(), &out);
  appendProblems("refinement", refinement.validate(), &out);
  appendProblems("confidence", confidence.validate(), &out);
  appendProblems("pose_refinement", pose_refinement.validate(), &out);
  appendProblems("direct_alignment", direct_alignment.validate(), &out);
  appendProblems("neighbour_depth", neighbour_depth.validate(), &out);
  appendProblems("rolling_shutter", rolling_shutter.validate(), &out);
  appendProblems("depth_filter", depth_filter.validate(), &out);
  appendProblems("surface", surface.validate(), &out);
  if (fusion.min_consistent_views > kMaxSourceViews)
    out << "fusion: min_consistent_views must be at most " << kMaxSourceViews << " (the most consistency views)\n";
  return out.str();
}

OnlineMapper::OnlineMapper(const OnlineMapperOptions& options, EstimateFunction estimate, FuseFunction fuse,
                           PublishFunction publish)
    : options_(options),
      estimate_(std::move(estimate)),
      store_(options.store),
      map_(options.map, keptSurface(options)),
      consistency_(store_, poses_, std::move(fuse), std::move(publish)) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("online mapper options:\n" + problems);
  if (!estimate_) throw InputError("online mapper: no estimate function");
  if (options.pose_refinement.enabled) pose_refiner_.reset(new PoseRefiner(options.pose_refinement));
  rolling_shutter_.setOptions(options.rolling_shutter);
  consistency_.setOptions(consistencyFusionOptions(options));
  temporal_.setOptions(options.depth_filter);
}

KeyframeResult OnlineMapper::process(Keyframe keyframe, bool next_follows) {
  const Clock::time_point start = Clock::now();
  KeyframeResult result;
  result.id = keyframe.id;
  result.camera = keyframe.camera;
  newest_centre_ = keyframe.camera.center();
  noteEvicted(store_.add(std::move(keyframe)), &result);
  rolling_shutter_.rectifyStored(result.id, estimates_started_, &store_);
  handOutUndelivered(&result);
  if (options_.depth_filter.enabled && store_.contains(result.id)) {
    const Clock::time_point filter_start = Clock::now();
    temporal_.observe(result.id, store_.keyframe(result.id).camera, store_.entry(result.id).grayImage(),
                      &result.refined_depths);
    result.times.depth_filter_ms += millisecondsSince(filter_start);
  }
  result.times.store_ms = millisecondsSince(start);
  const int64_t id = result.id;
  const Clock::time_point selection_start = Clock::now();
  result.selection = selectSources(store_, id, options_.sources);
  result.times.selection_ms = millisecondsSince(selection_start);

  if (result.selection.source_ids.empty()) {
    markSourceOnly(id, &result);
    if (store_.contains(id)) waiting_for_sources_.push_back(id);
    runDeferredFusion(&result);  // no estimate to overlap
    result.waiting_for_fusion = schedule_.waiting().size();
    result.times.total_ms = millisecondsSince(start);
    return result;
  }
  store_.setSources(id, result.selection.source_ids);
  try {
    estimateAndFuse(id, next_follows, &result);
  } catch (...) {
    // Dropped: nothing may name it again (a refinement would look it up).
    store_.remove(id);
    forgetKeyframe(id);
    keepUndelivered(&result);
    throw;
  }
  result.times.total_ms = millisecondsSince(start);
  return result;
}

void OnlineMapper::markSourceOnly(int64_t id, KeyframeResult* result) {
  // Done, with a depth map that has no valid pixel (and no normals: never a
  // consistency view of fusion).
  const PinholeCamera& camera = store_.keyframe(id).camera;
  DepthMap none;
  none.depth = ImageF(camera.width, camera.height, 1, std::numeric_limits<float>::quiet_NaN());
  noteEvicted(store_.attachDepth(id, std::move(none)), result);
}

std::vector<RefinedDepth> OnlineMapper::observe(const Keyframe& frame) {
  std::vector<RefinedDepth> refined;
  if (!options_.depth_filter.enabled || temporal_.active() == 0) return refined;
  const std::string problem = frame.camera.validate();
  if (!problem.empty()) throw InputError("frame: " + problem);
  temporal_.observe(/*id=*/std::numeric_limits<int64_t>::min(), frame.camera, toGray(frame.image), &refined);
  return refined;
}

std::vector<int64_t> OnlineMapper::addSourceView(Keyframe keyframe) {
  KeyframeResult result;
  const int64_t id = keyframe.id;
  newest_centre_ = keyframe.camera.center();
  noteEvicted(store_.add(std::move(keyframe)), &result);
  rolling_shutter_.rectifyStored(id, estimates_started_, &store_);
  markSourceOnly(id, &result);
  return result.evicted;
}

bool OnlineMapper::fuseDeferred(KeyframeResult* result) {
  if (!fusionDeferred()) return false;
  const Clock::time_point start = Clock::now();
  *result = KeyframeResult();
  result->id = deferred_.id;
  result->deferred_fusion = true;
  result->camera = store_.contains(deferred_.id) ? store_.keyframe(deferred_.id).camera : PinholeCamera();
  runDeferredFusion(result);
  result->waiting_for_fusion = schedule_.waiting().size();
  result->times.total_ms = millisecondsSince(start);
  return true;
}

void OnlineMapper::handOutUndelivered(KeyframeResult* result) {
  for (FusedKeyframe& fused : deferred_.undelivered.fused) result->fused.push_back(std::move(fused));
  const auto append = [](const std::vector<int64_t>& ids, std::vector<int64_t>* to) {
    to->insert(to->end(), ids.begin(), ids.end());
  };
  append(deferred_.undelivered.evicted, &result->evicted);
  append(deferred_.undelivered.evicted_before_fusion, &result->evicted_before_fusion);
  deferred_.undelivered = KeyframeResult();
}

void OnlineMapper::keepUndelivered(KeyframeResult* result) {
  // A call that throws hands out nothing: what it fused or evicted before
  // comes with the next result.
  deferred_.undelivered.fused = std::move(result->fused);
  deferred_.undelivered.evicted = std::move(result->evicted);
  deferred_.undelivered.evicted_before_fusion = std::move(result->evicted_before_fusion);
}

void OnlineMapper::runDeferredFusion(KeyframeResult* result) {
  handOutUndelivered(result);
  if (!deferred_.pending) return;
  deferred_.pending = false;
  fuseWaiting(result);
}

void OnlineMapper::fuseDeferredNow() {
  if (!deferred_.pending) return;
  deferred_.pending = false;
  fuseWaiting(&deferred_.undelivered);
}

bool OnlineMapper::estimateLate(KeyframeResult* result) {
  const Clock::time_point start = Clock::now();
  for (const int64_t id : waiting_for_sources_) {
    SourceSelection selection = selectSources(store_, id, options_.sources);
    if (selection.source_ids.empty()) continue;
    if (deferred_.pending) {
      // First: it may evict what this estimate would read; then choose again.
      fuseDeferredNow();
      return estimateLate(result) || fuseDeferred(result);
    }
    waiting_for_sources_.erase(std::find(waiting_for_sources_.begin(), waiting_for_sources_.end(), id));
    estimateStored(id, std::move(selection), /*late=*/true, start, result);
    return true;
  }
  return false;
}

bool OnlineMapper::refine(KeyframeResult* result) {
  fuseDeferredNow();  // first: it may evict what a refinement would read
  if (options_.refinement.max_refinements == 0) return fuseDeferred(result);
  const Clock::time_point start = Clock::now();
  // The keyframes that may choose anew this call: those nearest the newest
  // keyframe (a selection can only gain from keyframes near it, and the
  // newest is what changed), at most kSelectionsPerRefineCall of them.
  const auto due = [this](const KeyframeRecord& record) {
    return record.refinements < options_.refinement.max_refinements &&
           record.selection_checked_at != store_.revision();  // else what selection reads has not changed
  };
  std::vector<std::pair<double, int64_t>> nearest;
  for (const auto& [id, record] : records_) {
    if (due(record) && store_.contains(id))
      nearest.emplace_back((store_.keyframe(id).camera.center() - newest_centre_).norm(), id);
  }
  if (nearest.size() > static_cast<size_t>(kSelectionsPerRefineCall)) {
    std::nth_element(nearest.begin(), nearest.begin() + kSelectionsPerRefineCall, nearest.end());
    nearest.resize(kSelectionsPerRefineCall);
  }
  std::set<int64_t> may_choose;
  for (const auto& entry : nearest) may_choose.insert(entry.second);
  for (auto& [id, record] : records_) {
    if (stereoPosesMoved(id, record)) {
      ++record.pose_reestimates;
      estimateStored(id, selectSources(store_, id, options_.sources), /*late=*/false, start, result);
      return true;
    }
    if (!may_choose.count(id)) continue;
    SourceSelection selection = selectSources(store_, id, options_.sources);
    record.selection_checked_at = store_.revision();
    std::vector<int64_t> before = record.sources, now = selection.source_ids;
    std::sort(before.begin(), before.end());
    std::sort(now.begin(), now.end());
    if (now == before || selectionScore(selection) < options_.refinement.min_score_gain * record.score) continue;
    ++record.refinements;  // counted also when the estimate throws; the re-estimate keeps it
    estimateStored(id, std::move(selection), /*late=*/false, start, result);
    return true;
  }
  if (fuseDeferred(result)) return true;  // a deferred fusion's outcome, if any
  return fuseAgainstReplacedMaps(result);
}

bool OnlineMapper::fuseAgainstReplacedMaps(KeyframeResult* result) {
  while (const std::optional<int64_t> id = schedule_.takeFusedAgainstReplaced()) {
    const Clock::time_point start = Clock::now();
    std::vector<int64_t> views = consistency_.views(*id);
    if (views.size() < consistency_.requiredViews()) continue;
    fuseAgainNow(*id, std::move(views), start, result);
    return true;
  }
  return false;
}

void OnlineMapper::estimateStored(int64_t id, SourceSelection selection, bool late, Clock::time_point start,
                                  KeyframeResult* result) {
  *result = KeyframeResult();
  result->times.selection_ms = millisecondsSince(start);
  result->id = id;  // set first: the caller names the keyframe if the estimate throws
  result->late = late;
  result->refined = !late;
  result->camera = store_.keyframe(id).camera;
  result->selection = std::move(selection);
  handOutUndelivered(result);
  // Done already (a depth map, or none as a source only): nothing is pending,
  // so the sources need no protection from eviction during the estimate (no
  // fusion is deferred: the callers ran it first).
  try {
    estimateAndFuse(id, /*defer_fusion=*/false, result);
  } catch (...) {
    keepUndelivered(result);
    throw;
  }
  result->times.total_ms = millisecondsSince(start);
}

namespace {

// What the direct alignment holds each source's surface by: its depth map's
// pixels of a low matching cost. (Its fused points, consistent with other
// views, were measured too: too few in view on redkitchen.)
std::vector<std::vector<Eigen::Vector3f>> alignmentSurfaces(const KeyframeStore& store,
                                                            const std::vector<int64_t>& sources, double max_cost) {
  std::vector<std::vector<Eigen::Vector3f>> surfaces;
  for (int64_t source : sources) {
    const StoredKeyframe& entry = store.entry(source);
    surfaces.push_back(confidentDepthPoints(*entry.depth, entry.keyframe.camera, max_cost));
  }
  return surfaces;
}

}  // namespace

void OnlineMapper::estimateAndFuse(int64_t id, bool defer_fusion, KeyframeResult* result) {
  ++estimates_started_;  // images are read from here on (rectifyRollingShutter)
  const std::vector<int64_t>& sources = result->selection.source_ids;
  Clock::time_point start = Clock::now();
  result->depth_range = estimateDepthRange(store_, id, sources, options_.depth_range);
  result->times.depth_range_ms = millisecondsSince(start);
  start = Clock::now();
  // Grey images were converted once, when each keyframe was stored.
  DepthProblem problem;
  problem.reference_camera = store_.keyframe(id).camera;
  problem.reference_image = store_.entry(id).grayImage();
  // Keyframe ids as image keys: a GPU estimator uploads each keyframe once
  // (the pipeline forgets a key when its keyframe leaves the store).
  problem.reference_key = id;
  for (int64_t source : sources) {
    problem.source_cameras.push_back(store_.keyframe(source).camera);
    problem.source_images.push_back(store_.entry(source).grayImage());
    problem.source_keys.push_back(source);
  }
  problem.depth_min = result->depth_range.min;
  problem.depth_max = result->depth_range.max;
  // The problem borrows the start's pixels from here.
  const NeighbourDepthInputs neighbour_inputs =
      attachNeighbourDepth(store_, id, sources, result->refined, options_.neighbour_depth, &problem);
  result->times.problem_ms = millisecondsSince(start);
  if (options_.direct_alignment.enabled) {
    start = Clock::now();
    result->direct_alignment =
        alignSourcesDirectly(&problem, alignmentSurfaces(store_, sources, options_.direct_alignment.max_cost),
                             options_.direct_alignment);
    result->times.direct_alignment_ms = millisecondsSince(start);
  }
  if (pose_refiner_) {
    // The sources' cameras of this problem only; the store keeps the tracker's.
    start = Clock::now();
    result->pose_refinement = pose_refiner_->refine(&problem);
    poses_.record(id, problem, result->pose_refinement);
    if (!options_.pose_refinement.keyframe_bundle_adjustment ||
        !poses_.adjust(id, *pose_refiner_, store_, &problem, &map_))
      poses_.solvePoseGraph(store_, options_.pose_refinement, &map_);
    result->times.pose_refinement_ms = millisecondsSince(start);
  }
  start = Clock::now();
  result->depth = estimateWhileFusing(problem, result);
  result->times.estimate_ms = millisecondsSince(start);
  result->has_depth = true;
  if (result->refined && options_.refinement.keep_only_better) {
    const RefinementVerdict verdict =
        judgeRefinement(store_.entry(id).depth, result->depth, options_.refinement.confident_cost,
                        options_.refinement.max_confident_loss);
    result->refinement_evidence = verdict.reason;
    result->refinement_rejected = !verdict.keep_new;
  }
  KeyframeRecord& record = records_[id];
  record.sources = sources;  // also when rejected: the same selection is not tried again
  record.score = selectionScore(result->selection);
  record.stereo_reference = problem.reference_camera;
  record.stereo_sources.clear();
  for (size_t s = 0; s < sources.size() && s < problem.source_cameras.size(); ++s)
    record.stereo_sources[sources[s]] = problem.source_cameras[s];
  if (result->refinement_rejected) {
    result->waiting_for_fusion = schedule_.waiting().size();
    return;
  }
  start = Clock::now();
  noteEvicted(store_.attachDepth(id, result->depth), result);
  result->times.store_ms += millisecondsSince(start);
  if (!store_.contains(id)) return;
  if (options_.depth_filter.enabled && !result->refined) {
    start = Clock::now();
    temporal_.start(id, store_.keyframe(id).stamp, store_.keyframe(id).camera, store_.entry(id).grayImage(),
                    *result->depth, &result->refined_depths);
    result->times.depth_filter_ms += millisecondsSince(start);
  }
  if (result->refined && options_.refinement.fuse_neighbours_again) schedule_.depthMapReplaced(id);
  // A keyframe with a depth map waits for fusion (a refined one again); this
  // depth map may also complete earlier waiting keyframes.
  schedule_.wait(id);
  if (defer_fusion) {
    deferred_.pending = true;  // during the next keyframe's estimate
    deferred_.id = id;
  } else {
    fuseWaiting(result);
  }
  result->waiting_for_fusion = schedule_.waiting().size();
}

DepthMap OnlineMapper::estimateWhileFusing(const DepthProblem& problem, KeyframeResult* result) {
  if (!deferred_.pending) return estimate_(problem);
  deferred_.pending = false;
  // Fusion attaches points to the waiting keyframes; the store makes room by
  // evicting, and must not reach the images this estimate reads.
  size_t most_point_bytes = 0;
  for (int64_t waiting : schedule_.waiting()) {
    const PinholeCamera& camera = store_.keyframe(waiting).camera;
    most_point_bytes += static_cast<size_t>(camera.width) * camera.height * sizeof(KeyframePoint);
  }
  if (store_.bytesBeforePendingEvicted(schedule_.waiting()) < most_point_bytes) {
    fuseWaiting(result);
    return estimate_(problem);
  }
  if (!estimate_worker_) estimate_worker_.reset(new SerialWorker());
  std::future<DepthMap> estimate =
      estimate_worker_->submit(std::function<DepthMap()>([this, &problem] { return estimate_(problem); }));
  const Clock::time_point start = Clock::now();
  try {
    fuseWaiting(result);
  } catch (...) {
    estimate.wait();  // it borrows the problem's images
    throw;
  }
  result->times.fused_during_estimate_ms = millisecondsSince(start);
  return estimate.get();
}

OnlineMapper::Forgotten OnlineMapper::forgetKeyframe(int64_t id) {
  Forgotten forgotten;
  records_.erase(id);
  if (pose_refiner_) pose_refiner_->forget(id);
  poses_.forget(id);  // its points stay in the map where they are
  const auto without_depth = std::find(waiting_for_sources_.begin(), waiting_for_sources_.end(), id);
  if (without_depth != waiting_for_sources_.end()) {
    waiting_for_sources_.erase(without_depth);
    forgotten.was_waiting_for_sources = true;
  }
  forgotten.was_waiting_for_fusion = schedule_.forget(id);
  temporal_.forget(id);
  return forgotten;
}

void OnlineMapper::noteEvicted(const std::vector<int64_t>& evicted, KeyframeResult* result) {
  for (int64_t id : evicted) {
    result->evicted.push_back(id);
    const Forgotten forgotten = forgetKeyframe(id);
    if (forgotten.was_waiting_for_sources) ++evicted_without_depth_;
    if (!forgotten.was_waiting_for_fusion) continue;
    result->evicted_before_fusion.push_back(id);
    ++evicted_before_fusion_;
  }
}

void OnlineMapper::fuseWaiting(KeyframeResult* result) {
  const size_t required = consistency_.requiredViews();
  // A snapshot: fusing one keyframe may evict another (attachPoints).
  const std::vector<int64_t> candidates = schedule_.waiting();
  for (int64_t id : candidates) {
    if (!schedule_.isWaiting(id)) continue;  // evicted meanwhile
    Clock::time_point start = Clock::now();
    std::vector<int64_t> views = consistency_.views(id);
    result->times.fusion_ms += millisecondsSince(start);
    if (views.size() < required) continue;
    fuseNow(id, std::move(views), result);
  }
  schedule_.depthMapChecked();
}

bool OnlineMapper::fuseAgain(KeyframeResult* result) {
  if (fusionDeferred()) return fuseDeferred(result);  // newer work first
  const Clock::time_point start = Clock::now();
  // Nothing changed for the others since they were checked (an idle
  // pipeline asks again and again); a refined keyframe waits anew.
  for (int64_t id : schedule_.underfusedToCheck()) {
    std::vector<int64_t> views = consistency_.views(id);
    schedule_.markChecked(id);
    if (views.size() <= schedule_.underfusedViews(id)) continue;
    fuseAgainNow(id, std::move(views), start, result);
    return true;
  }
  return false;
}

void OnlineMapper::fuseAgainNow(int64_t id, std::vector<int64_t> views, Clock::time_point start,
                                KeyframeResult* result) {
  *result = KeyframeResult();
  result->id = id;
  result->fused_again = true;
  result->camera = store_.keyframe(id).camera;
  result->times.fusion_ms = millisecondsSince(start);
  fuseNow(id, std::move(views), result);
  result->waiting_for_fusion = schedule_.waiting().size();
  result->times.total_ms = millisecondsSince(start);
}

void OnlineMapper::fuseNow(int64_t id, std::vector<int64_t> views, KeyframeResult* result) {
  const size_t counted =
      std::min(consistency_.viewCap(), static_cast<size_t>(defaultConfidenceCalibration().max_views));
  // With the confidence off too: more views confirm more of the depth map,
  // so the map's coverage does not depend on whether the later keyframes
  // were estimated before this one was fused (a machine's speed).
  const bool too_few = options_.confidence.again_with_more_views && views.size() < counted;
  FusedKeyframe fused;
  fused.id = id;
  fused.again = schedule_.fuse(id, views, too_few);
  fused.consistency_ids = std::move(views);
  fused.stamp = store_.keyframe(id).stamp;
  fused.camera = store_.keyframe(id).camera;
  Clock::time_point start = Clock::now();
  fused.points = consistency_.fuse(id, fused.consistency_ids);
  result->times.fusion_ms += millisecondsSince(start);
  if (options_.confidence.enabled) {
    start = Clock::now();
    fused.published = consistency_.publish(id, fused.consistency_ids);
    if (options_.depth_filter.enabled) temporal_.setPublished(id, fused.published);
    result->times.confidence_ms += millisecondsSince(start);
  }
  if (!fused.points->empty()) {
    start = Clock::now();
    noteEvicted(store_.attachPoints(id, fused.points), result);
    result->times.store_ms += millisecondsSince(start);
    start = Clock::now();
    map_.add(id, poses_.mapPose(id, store_), fused.points, surfaceDepth(id, fused.published),
             options_.map_in_background);  // replaces
  } else {
    start = Clock::now();
    map_.remove(id);  // the refined depth map confirms nothing of the old points
  }
  result->times.map_ms += millisecondsSince(start);
  if (id == result->id) result->fused_now = true;
  result->fused.push_back(std::move(fused));
}

TsdfMapOptions keptSurface(const OnlineMapperOptions& options) {
  TsdfMapOptions kept = options.surface;
  kept.enabled = options.surface.enabled && options.confidence.enabled;
  return kept;
}

Shared<SurfaceDepth> OnlineMapper::surfaceDepth(int64_t id, const PublishedDepth& published) const {
  if (!options_.surface.enabled || published.empty()) return Shared<SurfaceDepth>();
  SurfaceDepth full;
  full.camera = store_.keyframe(id).camera;
  full.depth = published.depth;
  full.weight = published.confidence;
  for (float& weight : full.weight.data) {
    if (!(weight >= 0) || !std::isfinite(weight)) weight = 0;  // no confidence: no weight
  }
  full.colour = store_.keyframe(id).image;
  // Subsampled here, so that the background update copies a quarter of it.
  return Shared<SurfaceDepth>(subsampledSurfaceDepth(full, options_.surface.max_image_width));
}

OnlineMapper::~OnlineMapper() = default;  // map_ waits for its update in flight

bool OnlineMapper::stereoPosesMoved(int64_t id, const KeyframeRecord& record) const {
  // Relative depth error of a pose change at a parallax of ~3 deg (10 cm at
  // 2 m): 0.01 deg of rotation ~0.3 %; a baseline 0.2 % longer 0.2 %.
  // (pose_refinement.h: max_pose_reestimates)
  constexpr double kMaxTurnRad = 0.01 * M_PI / 180, kMaxDirectionRad = 0.05 * M_PI / 180;
  const PoseRefinementOptions& options = options_.pose_refinement;
  const double max_length_change = options.reestimate_length_change;
  if (!options.enabled || !options.keyframe_bundle_adjustment || record.stereo_sources.empty() ||
      record.pose_reestimates >= options.max_pose_reestimates || !store_.contains(id))
    return false;
  for (const auto& [source, used] : record.stereo_sources) {
    PinholeCamera now = used;
    if (!store_.contains(source) || !poses_.placeView(id, record.stereo_reference, source, &now)) continue;
    const Eigen::Matrix3d turn = now.R * used.R.transpose();
    const Eigen::Vector3d used_centre = record.stereo_reference.R * used.center() + record.stereo_reference.t;
    const Eigen::Vector3d now_centre = record.stereo_reference.R * now.center() + record.stereo_reference.t;
    const double length = used_centre.norm();
    if (!(length > 0)) continue;
    if (Eigen::AngleAxisd(turn).angle() > kMaxTurnRad ||
        std::abs(now_centre.norm() / length - 1) > max_length_change ||
        std::acos(std::clamp(now_centre.normalized().dot(used_centre.normalized()), -1.0, 1.0)) > kMaxDirectionRad)
      return true;
  }
  return false;
}

bool OnlineMapper::updatePose(int64_t id, const Eigen::Isometry3d& camera_to_world) {
  const std::string problem = validateRigidPose(camera_to_world);
  if (!problem.empty()) throw InputError("keyframe " + std::to_string(id) + ": " + problem);
  const bool stored = store_.contains(id);
  if (stored) store_.updatePose(id, camera_to_world);
  poses_.dropCorrection(id);
  schedule_.posesChanged();  // views follow the poses
  return map_.updatePose(id, camera_to_world) || stored;
}

void OnlineMapper::reset() {
  store_ = KeyframeStore(options_.store);
  schedule_.clear();
  temporal_.clear();
  evicted_before_fusion_ = 0;
  waiting_for_sources_.clear();
  evicted_without_depth_ = 0;
  rolling_shutter_.reset();
  records_.clear();
  deferred_ = DeferredFusion();
  if (pose_refiner_) pose_refiner_->forgetAll();
  poses_.clear();
  map_.reset(options_.map, keptSurface(options_));
}

void OnlineMapper::setOptions(const OnlineMapperOptions& options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("online mapper options:\n" + problems);
  OnlineMapperOptions kept = options;
  kept.store = options_.store;
  kept.surface = options_.surface;  // its bounds and voxels stay
  const VoxelMap& map = map_.map();  // after the update in flight
  if (options.map.leaf_size != options_.map.leaf_size) {
    // A new voxel size: rebuild the map from the stored keyframes' points.
    VoxelMapOptions map_options = options_.map;
    map_options.leaf_size = options.map.leaf_size;
    VoxelMap rebuilt(map_options);
    for (int64_t id : map.keyframeIds()) {
      if (!store_.contains(id)) continue;
      rebuilt.addKeyframe(id, map.pose(id), store_.entry(id).points);
    }
    map_.replace(std::move(rebuilt));
  }
  if (options.map.min_points_per_voxel != map_.map().options().min_points_per_voxel)
    map_.setMinPointsPerVoxel(options.map.min_points_per_voxel);  // what is published, not the voxels
  kept.map = map_.map().options();
  for (auto& entry : records_) entry.second.selection_checked_at = KeyframeRecord::kNeverChecked;  // new criteria
  if (!options.pose_refinement.enabled) {
    pose_refiner_.reset();
  } else if (!pose_refiner_ || pose_refiner_->options() != options.pose_refinement) {
    pose_refiner_.reset(new PoseRefiner(options.pose_refinement));  // features of other settings: detected again
  }
  rolling_shutter_.setOptions(kept.rolling_shutter);
  consistency_.setOptions(consistencyFusionOptions(kept));
  temporal_.setOptions(kept.depth_filter);
  if (!kept.depth_filter.enabled) temporal_.clear();
  options_ = kept;
}

}  // namespace amhmvs
