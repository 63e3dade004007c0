#include "map_outputs.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <numeric>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/eval/pose_alignment.h"
#include "amhmvs_mapping/io/depth_preview.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "amhmvs_mapping/mapping/map_export.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

// The stage times by name, in the order of the logs.
const std::vector<std::pair<const char*, double StageTimes::*>>& stageFields() {
  static const std::vector<std::pair<const char*, double StageTimes::*>> fields = {
      {"queue_wait_ms", &StageTimes::queue_wait_ms}, {"selection_ms", &StageTimes::selection_ms},
      {"depth_range_ms", &StageTimes::depth_range_ms}, {"problem_ms", &StageTimes::problem_ms},
      {"direct_alignment_ms", &StageTimes::direct_alignment_ms},
      {"pose_refinement_ms", &StageTimes::pose_refinement_ms}, {"estimate_ms", &StageTimes::estimate_ms},
      {"fusion_ms", &StageTimes::fusion_ms},                   {"confidence_ms", &StageTimes::confidence_ms},
      {"map_ms", &StageTimes::map_ms},                         {"depth_filter_ms", &StageTimes::depth_filter_ms},
      {"total_ms", &StageTimes::total_ms}};
  return fields;
}

const std::vector<const char*> kAccuracyColumns = {"within_1pct", "within_2pct", "within_5pct", "within_10pct"};
// Map accuracy: share of map points within these distances of the ground-truth surface.
const std::vector<double> kMapThresholds = {0.02, 0.05};
// The ground-truth surface is the keyframes' ground-truth depth back-projected
// at about this many samples per row (every pixel of a 320-wide file, every
// 2nd of a 640-wide one): about 1 cm apart at 3 m for a 60 degree view, fine
// enough for a 2 cm threshold, without millions of points per keyframe.
constexpr int kTruthSurfaceColumns = 320;

std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      out += ' ';
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string id6(int64_t id) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld", static_cast<long long>(id));
  return name;
}

const char* kindOf(const KeyframeResult& result) {
  if (result.fused_again) return "fused_again";
  if (result.deferred_fusion) return "deferred_fusion";
  if (!result.has_depth) return "source_only";
  if (result.refined) return "refined";
  return result.late ? "late" : "new";
}

std::FILE* openLog(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (!file) throw InputError(path + ": cannot open for writing");
  return file;
}

// "name": value pairs of a JSON object.
class JsonFields {
 public:
  void add(const std::string& name, const std::string& json) {
    text_ += (text_.empty() ? "" : ", ") + quoted(name) + ": " + json;
  }
  std::string object() const { return "{" + text_ + "}"; }

 private:
  std::string text_;
};

// "within_<t>cm_pct" for each of kMapThresholds, from the shares in `pct`.
void addWithinFields(const std::vector<double>& pct, JsonFields* fields) {
  for (size_t i = 0; i < kMapThresholds.size(); ++i)
    fields->add("within_" + number(100 * kMapThresholds[i]) + "cm_pct", number(pct[i]));
}

// The points of every keyframe, in one vector.
std::vector<Eigen::Vector3f> allPoints(const std::map<int64_t, std::vector<Eigen::Vector3f>>& per_keyframe) {
  std::vector<Eigen::Vector3f> all;
  for (const auto& entry : per_keyframe) all.insert(all.end(), entry.second.begin(), entry.second.end());
  return all;
}

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

double mean(const std::vector<double>& values) {
  return values.empty() ? NAN : std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

JsonFields accuracyFields(const DepthComparison& comparison) {
  JsonFields fields;
  for (size_t i = 0; i < kAccuracyColumns.size(); ++i) {
    fields.add(kAccuracyColumns[i], number(100.0 * comparison.accuracy.fraction(i)));
  }
  fields.add("completeness_pct", number(100.0 * comparison.completeness()));
  fields.add("truth_pixels", std::to_string(comparison.truth_pixels));
  return fields;
}

// The comparisons of all keyframes as one.
DepthComparison pooledComparison(const std::map<int64_t, DepthComparison>& per_keyframe) {
  DepthComparison pooled;
  for (const auto& entry : per_keyframe) pooled.merge(entry.second);
  return pooled;
}

// Published depth: a keyframe never fused published nothing (its truth
// pixels count, none covered).
DepthComparison pooledPublished(const std::map<int64_t, DepthComparison>& estimated,
                                const std::map<int64_t, DepthComparison>& published) {
  DepthComparison pooled;
  for (const auto& entry : estimated) {
    const auto found = published.find(entry.first);
    if (found != published.end()) {
      pooled.merge(found->second);
    } else {
      pooled.truth_pixels += entry.second.truth_pixels;
    }
  }
  return pooled;
}

}  // namespace

struct MapOutputs::Row {
  size_t index = 0;  // results so far, 1-based
  PipelineOutput output;
};

namespace {

// One value of a log row, as the CSV and the JSON write it.
struct Cell {
  std::string name, csv, json;
};

Cell numberCell(const std::string& name, double value) {
  return {name, std::isfinite(value) ? number(value) : "", number(value)};
}

Cell textCell(const std::string& name, const std::string& text) {
  return {name, text, text.empty() ? "null" : quoted(text)};
}

Cell idListCell(const std::string& name, const std::vector<int64_t>& ids) {
  Cell cell{name, "", ""};
  for (int64_t id : ids) {
    cell.csv += (cell.csv.empty() ? "" : " ") + std::to_string(id);
    cell.json += (cell.json.empty() ? "" : ", ") + std::to_string(id);
  }
  cell.json = "[" + cell.json + "]";
  return cell;
}

// What the pose refinement did (empty / null when it did not run): sources
// refined and rejected, inliers, reprojection RMS before and after (pixels),
// the largest correction.
std::vector<Cell> poseRefinementCells(const PoseRefinementResult& pose) {
  int inliers = 0;
  for (const SourcePoseRefinement& source : pose.sources)
    if (source.outcome == SourcePoseOutcome::kRefined) inliers += source.inliers;
  const bool ran = pose.ran;
  return {numberCell("pose_sources_refined", ran ? pose.refinedCount() : NAN),
          numberCell("pose_sources_rejected", ran ? pose.rejectedCount() : NAN),
          numberCell("pose_inliers", ran ? inliers : NAN),
          numberCell("pose_rms_before_px", ran ? pose.rmsBeforePx() : NAN),
          numberCell("pose_rms_after_px", ran ? pose.rmsAfterPx() : NAN),
          numberCell("pose_correction_mm", ran ? 1000 * pose.maxCorrectionM() : NAN),
          numberCell("pose_correction_deg", ran ? pose.maxCorrectionDeg() : NAN)};
}

// Per source (JSON only): matches, inliers, RMS, correction, outcome.
std::string poseSourcesJson(const PoseRefinementResult& pose) {
  std::string list;
  for (const SourcePoseRefinement& source : pose.sources) {
    JsonFields fields;
    fields.add("id", std::to_string(source.key));
    fields.add("matches", std::to_string(source.matches));
    fields.add("inliers", std::to_string(source.inliers));
    fields.add("rms_before_px", number(source.rms_before_px));
    fields.add("rms_after_px", number(source.rms_after_px));
    fields.add("correction_mm", number(1000 * source.correction_m));
    fields.add("correction_deg", number(source.correction_deg));
    fields.add("outcome", quoted(sourcePoseOutcomeName(source.outcome)));
    list += (list.empty() ? "" : ", ") + fields.object();
  }
  return "[" + list + "]";
}

std::string alignmentSourcesJson(const DirectAlignmentResult& alignment, const std::vector<int64_t>& source_ids) {
  std::string list;
  for (size_t s = 0; s < alignment.sources.size(); ++s) {
    const SourceAlignment& source = alignment.sources[s];
    JsonFields fields;
    fields.add("id", s < source_ids.size() ? std::to_string(source_ids[s]) : "null");
    fields.add("points", std::to_string(source.points));
    fields.add("rms_before_grey", number(source.rms_before_grey));
    fields.add("rms_after_grey", number(source.rms_after_grey));
    fields.add("correction_mm", number(1000 * source.correction_m));
    fields.add("correction_deg", number(source.correction_deg));
    fields.add("shift_across_px", number(source.shift_across_px));
    fields.add("shift_along_px", number(source.shift_along_px));
    fields.add("gain", number(source.gain));
    fields.add("bias", number(source.bias));
    fields.add("outcome", quoted(sourceAlignmentOutcomeName(source.outcome)));
    list += (list.empty() ? "" : ", ") + fields.object();
  }
  return "[" + list + "]";
}

// Median of the estimate's finite matching costs (NaN without any).
double medianCost(const ImageF& cost) {
  std::vector<double> values;
  values.reserve(cost.data.size());
  for (float value : cost.data) {
    if (std::isfinite(value)) values.push_back(value);
  }
  return values.empty() ? NAN : medianOf(std::move(values));
}

// The row of one result: identity, sources, depth range, stage times, fusion.
std::vector<Cell> resultCells(const KeyframeResult& result, const PosedFrame* frame) {
  const bool depth = result.has_depth;
  std::vector<Cell> cells = {
      {"id", std::to_string(result.id), std::to_string(result.id)},
      textCell("frame", frame ? frame->name : ""),
      numberCell("stamp", frame ? frame->stamp : NAN),
      textCell("kind", kindOf(result)),
      idListCell("sources", result.selection.source_ids),
      numberCell("depth_min", depth ? result.depth_range.min : NAN),
      numberCell("depth_max", depth ? result.depth_range.max : NAN),
      textCell("depth_range_source", depth ? depthRangeSourceName(result.depth_range.source) : ""),
      {"width", std::to_string(result.camera.width), std::to_string(result.camera.width)},
      {"height", std::to_string(result.camera.height), std::to_string(result.camera.height)},
      textCell("backend", depth ? backendName(result.depth->backend) : "")};
  for (const auto& field : stageFields()) cells.push_back(numberCell(field.first, result.times.*field.second));
  cells.push_back(numberCell("estimator_ms", depth ? result.depth->milliseconds : NAN));
  cells.push_back(numberCell("median_cost", depth ? medianCost(result.depth->cost) : NAN));
  for (const Cell& cell : poseRefinementCells(result.pose_refinement)) cells.push_back(cell);
  std::vector<int64_t> fused_ids;
  size_t fused_points = 0;
  for (const FusedKeyframe& fused : result.fused) {
    fused_ids.push_back(fused.id);
    fused_points += fused.points->size();
  }
  cells.push_back(idListCell("fused_ids", fused_ids));
  cells.push_back({"fused_points", std::to_string(fused_points), std::to_string(fused_points)});
  return cells;
}

// Accuracy columns (empty / null without ground truth).
std::vector<Cell> accuracyCells(const DepthComparison* comparison) {
  std::vector<Cell> cells;
  for (size_t i = 0; i < kAccuracyColumns.size(); ++i) {
    cells.push_back(numberCell(kAccuracyColumns[i], comparison ? 100.0 * comparison->accuracy.fraction(i) : NAN));
  }
  cells.push_back(numberCell("completeness_pct", comparison ? 100.0 * comparison->completeness() : NAN));
  cells.push_back(numberCell("truth_pixels", comparison ? comparison->truth_pixels : NAN));
  return cells;
}

// The progress line of one result.
std::string progressLine(size_t index, const KeyframeResult& result, const PosedFrame* frame,
                         const DepthComparison* comparison) {
  std::ostringstream line;
  line << "[" << index << "] keyframe " << result.id << " " << (frame ? frame->name : "") << ": " << kindOf(result);
  char text[200];
  if (result.has_depth) {
    std::snprintf(text, sizeof(text), ", %zu sources, depth %.2f-%.2f m (%s), %.0f ms (estimate %.0f)",
                  result.selection.source_ids.size(), result.depth_range.min, result.depth_range.max,
                  depthRangeSourceName(result.depth_range.source), result.times.total_ms, result.times.estimate_ms);
    line << text;
  }
  if (!result.fused.empty()) {
    line << ", fused";
    for (const FusedKeyframe& fused : result.fused) line << " " << fused.id;
  }
  if (comparison) {
    std::snprintf(text, sizeof(text), ", within 5/10 %%: %.1f/%.1f %%, complete %.0f %%",
                  100 * comparison->accuracy.fraction(2), 100 * comparison->accuracy.fraction(3),
                  100 * comparison->completeness());
    line << text;
  }
  return line.str();
}

}  // namespace

MapOutputs::MapOutputs(const std::string& dir, const MapToolOptions& options, const PosedSequence& sequence)
    : dir_(dir), options_(options), sequence_(sequence), writer_(options.writer_queue) {
  for (size_t i = 0; i < sequence.frames.size(); ++i) frame_of_id_[sequence.frames[i].id] = i;
  const std::vector<std::pair<std::string, bool>> folders = {
      {dir, true}, {dir + "/depth", options.write_depth}, {dir + "/clouds", options.write_clouds},
      {dir + "/previews", options.write_previews},
      {dir + "/confidence", options.write_confidence && options.pipeline.mapper.confidence.enabled}};
  for (const auto& [folder, wanted] : folders) {
    std::error_code error;
    if (wanted) fs::create_directories(folder, error);
    if (error) throw InputError(folder + ": cannot create folder (" + error.message() + ")");
  }
  csv_ = openLog(dir + "/keyframes.csv");
  jsonl_ = openLog(dir + "/keyframes.jsonl");
  // The header: the cells of an empty result.
  std::vector<Cell> header = resultCells(KeyframeResult(), nullptr);
  for (const Cell& cell : accuracyCells(nullptr)) header.push_back(cell);
  for (size_t i = 0; i < header.size(); ++i) std::fprintf(csv_, "%s%s", i ? "," : "", header[i].name.c_str());
  std::fprintf(csv_, "\n");
}

MapOutputs::~MapOutputs() {
  // The writer's jobs use the logs: let them end first (after an error too).
  try {
    writer_.finish();
  } catch (...) {  // already reported, or the run is failing anyway
  }
  if (csv_) std::fclose(csv_);
  if (jsonl_) std::fclose(jsonl_);
}

void MapOutputs::add(const PipelineOutput& output) {
  auto row = std::make_shared<Row>();
  row->index = ++results_;
  row->output = output;
  const auto start = std::chrono::steady_clock::now();
  writer_.submit([this, row] { write(*row); });
  submit_blocked_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

void MapOutputs::writeDepth(int64_t id, const ImageF& depth, const DepthRangeEstimate& range) {
  const std::string name = id6(id);
  if (options_.write_depth) writePfm(dir_ + "/depth/" + name + ".pfm", depth);
  if (options_.write_previews) {
    // No valid depth: the estimate's range.
    writePng(dir_ + "/previews/" + name + ".png",
             depthPreview(depth, static_cast<float>(range.min), static_cast<float>(range.max)));
  }
}

void MapOutputs::writeFiles(const KeyframeResult& result) {
  if (result.has_depth) {
    depth_ranges_[result.id] = result.depth_range;
    keyframe_pixels_[result.id] = static_cast<size_t>(result.camera.width) * result.camera.height;
  }
  // With the confidence, a depth map is published when its keyframe is fused.
  if (result.has_depth && !publishesWhenFused()) writeDepth(result.id, result.depth->depth, result.depth_range);
  for (const FusedKeyframe& fused : result.fused) {
    if (fused.published.empty()) continue;
    writeDepth(fused.id, fused.published.depth, depth_ranges_[fused.id]);
    if (options_.write_confidence)
      writePfm(dir_ + "/confidence/" + id6(fused.id) + ".pfm", fused.published.confidence);
  }
  // depth_filter: published again, refined by the frames since.
  for (const RefinedDepth& refined : result.refined_depths) {
    writeDepth(refined.id, refined.published.depth, depth_ranges_[refined.id]);
    if (options_.write_confidence)
      writePfm(dir_ + "/confidence/" + id6(refined.id) + ".pfm", refined.published.confidence);
  }
  if (!options_.write_clouds) return;
  for (const FusedKeyframe& fused : result.fused) {
    writePly(dir_ + "/clouds/" + id6(fused.id) + ".ply",
             keyframeWorldCloud(fused.points, cameraToWorld(fused.camera)));
  }
}

void MapOutputs::writeKeyframePoses(const VoxelMap& map) const {
  std::vector<StampedPose> poses;
  for (int64_t id : map.keyframeIds()) {
    const auto frame = frame_of_id_.find(id);
    if (frame != frame_of_id_.end()) poses.push_back({sequence_.frames[frame->second].stamp, map.pose(id)});
  }
  std::sort(poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return a.first < b.first; });
  writeTumTrajectory(dir_ + "/keyframe_poses.txt", poses,
                     "The map's keyframe poses (camera-to-world, where map.ply placed each keyframe's points):\n"
                     "the tracker's, or corrected by the pose graph or the bundle adjustment.\n"
                     "stamp tx ty tz qx qy qz qw");
}

bool MapOutputs::publishesWhenFused() const { return options_.pipeline.mapper.confidence.enabled; }

std::string MapOutputs::comparePublished(const KeyframeResult& result) {
  JsonFields list;
  std::string rows;
  // The summary counts each keyframe's last published depth.
  const auto compare = [&](int64_t id, const PinholeCamera& camera, const PublishedDepth& published, int frames) {
    const auto frame_it = frame_of_id_.find(id);
    if (published.empty() || frame_it == frame_of_id_.end()) return;
    const PosedFrame& frame = sequence_.frames[frame_it->second];
    if (!frame.ground_truth.present()) return;
    const ImageF truth = groundTruthDepthIn(frame.ground_truth, camera);
    const DepthComparison comparison = compareDepth(published.depth, truth);
    published_accuracy_[id] = comparison;
    const auto mask = weak_texture_masks_.find(id);
    if (mask != weak_texture_masks_.end() && mask->second.sameSize(truth.width, truth.height))
      weak_published_accuracy_[id] = compareDepth(published.depth, truth, &mask->second);
    JsonFields row = accuracyFields(comparison);
    row.add("id", std::to_string(id));
    if (frames > 0) row.add("filter_frames", std::to_string(frames));
    rows += (rows.empty() ? "" : ", ") + row.object();
  };
  for (const FusedKeyframe& fused : result.fused) compare(fused.id, fused.camera, fused.published, 0);
  for (const RefinedDepth& refined : result.refined_depths)
    compare(refined.id, refined.camera, refined.published, refined.frames);
  return "[" + rows + "]";
}

bool MapOutputs::compareWithTruth(const KeyframeResult& result, const PosedFrame* frame,
                                  DepthComparison* comparison) {
  if (!result.has_depth || !frame || !frame->ground_truth.present()) return false;
  const DepthMapView truth = readGroundTruthDepth(frame->ground_truth, result.camera);
  const ImageF truth_here = groundTruthDepthIn(truth, frame->ground_truth.registered, result.camera);
  *comparison = compareDepth(result.depth->depth, truth_here);
  accuracy_[result.id] = *comparison;  // a refinement replaces the earlier depth map
  auto mask = weak_texture_masks_.find(result.id);
  if (mask == weak_texture_masks_.end()) {
    const ImageU8 grey = resizeArea(toGray(readImage(frame->image_path)), result.camera.width, result.camera.height);
    mask = weak_texture_masks_.emplace(result.id, weakTextureMask(grey)).first;
  }
  weak_accuracy_[result.id] = compareDepth(result.depth->depth, truth_here, &mask->second);
  if (!truth_points_.count(result.id)) {
    const int stride = std::max(1, truth.depth.width / kTruthSurfaceColumns);
    truth_points_[result.id] = backprojectDepthMaps({trueSurfaceView(truth, *frame)}, stride);
    if (frame->true_camera) {
      tracker_placed_truth_[result.id] = backprojectDepthMaps({truth}, stride);
      tracker_poses_[result.id] = cameraToWorld(result.camera);
      true_poses_[result.id] = cameraToWorld(*frame->true_camera);
    }
  }
  return true;
}

void MapOutputs::write(const Row& row) {
  const KeyframeResult& result = row.output.result;
  if (result.frame_only) {  // a frame between keyframes: refined depths only, no row
    writeFiles(result);
    comparePublished(result);
    return;
  }
  const auto frame_it = frame_of_id_.find(result.id);
  const PosedFrame* frame = frame_it == frame_of_id_.end() ? nullptr : &sequence_.frames[frame_it->second];
  ++kinds_[kindOf(result)];
  if (result.has_depth) {
    total_ms_.push_back(result.times.total_ms);
    estimate_ms_.push_back(result.times.estimate_ms);
  }
  if (result.direct_alignment.ran) {
    direct_alignment_ms_.push_back(result.times.direct_alignment_ms);
    for (const SourceAlignment& source : result.direct_alignment.sources)
      ++alignment_outcomes_[sourceAlignmentOutcomeName(source.outcome)];
  }
  if (result.pose_refinement.ran) {
    pose_refinement_ms_.push_back(result.times.pose_refinement_ms);
    for (const SourcePoseRefinement& source : result.pose_refinement.sources)
      ++pose_outcomes_[sourcePoseOutcomeName(source.outcome)];
  }
  writeFiles(result);
  DepthComparison comparison;
  const bool has_truth = compareWithTruth(result, frame, &comparison);

  std::vector<Cell> cells = resultCells(result, frame);
  JsonFields json;
  for (const Cell& cell : cells) json.add(cell.name, cell.json);
  json.add("pose_refinement_sources", poseSourcesJson(result.pose_refinement));
  json.add("direct_alignment_sources", alignmentSourcesJson(result.direct_alignment, result.selection.source_ids));
  json.add("accuracy", has_truth ? accuracyFields(comparison).object() : "null");
  json.add("published_accuracy", comparePublished(result));
  for (const Cell& cell : accuracyCells(has_truth ? &comparison : nullptr)) cells.push_back(cell);
  for (size_t i = 0; i < cells.size(); ++i) std::fprintf(csv_, "%s%s", i ? "," : "", cells[i].csv.c_str());
  std::fprintf(csv_, "\n");
  std::fprintf(jsonl_, "%s\n", json.object().c_str());
  std::fflush(csv_);
  std::fflush(jsonl_);
  if (!options_.quiet) {
    std::cerr << progressLine(row.index, result, frame, has_truth ? &comparison : nullptr) << "\n";
  }
}

std::string MapOutputs::finish(const MappingPipeline& pipeline, const MapRunTotals& totals) {
  writer_.finish();
  std::fflush(csv_);
  std::fflush(jsonl_);
  std::string line;
  const std::string summary = summaryJson(pipeline, totals, &line);
  writeFileAtomically(dir_ + "/summary.json", summary + "\n", "summary");
  return line;
}

std::string MapOutputs::summaryJson(const MappingPipeline& pipeline, const MapRunTotals& totals,
                                    std::string* line) {
  // The map: written, and judged against the ground-truth surface.
  std::vector<Eigen::Vector3f> map_points;
  // With corrected map poses: the exact depth placed where the map put each keyframe.
  const PoseRefinementOptions& refinement = options_.pipeline.mapper.pose_refinement;
  const bool map_poses_corrected =
      refinement.enabled && (refinement.correct_map_poses || refinement.keyframe_bundle_adjustment);
  std::vector<Eigen::Vector3f> map_placed_truth;
  // Per keyframe in the map: the share of its pixels whose fused point is in an exported voxel.
  std::vector<double> pixels_in_map_pct;
  // Where true poses are known: the map's keyframe poses and those.
  std::vector<Eigen::Isometry3d> map_poses, true_poses;
  TriangleMesh mesh;  // the surface map's, when it is on
  size_t surface_blocks = 0, surface_bytes = 0;
  pipeline.withMapper([&](const OnlineMapper& mapper) {
    // Exported once: written as map.ply and judged below.
    const PointCloud cloud = mapper.map().exportCloud();
    writePointCloud(dir_ + "/map.ply", cloud);
    if (mapper.surface()) {
      mesh = mapper.surface()->mesh();
      surface_blocks = mapper.surface()->blockCount();
      surface_bytes = mapper.surface()->memoryBytes();
      writeMeshPly(dir_ + "/mesh.ply", mesh);
    }
    writeKeyframePoses(mapper.map());
    map_points = cloud.points;
    for (const auto& [id, pixels] : keyframe_pixels_) {
      if (mapper.map().contains(id) && pixels > 0)
        pixels_in_map_pct.push_back(100.0 * mapper.map().exportedPointCount(id) / pixels);
    }
    for (const auto& entry : true_poses_) {
      if (!mapper.map().contains(entry.first)) continue;
      map_poses.push_back(mapper.map().pose(entry.first));
      true_poses.push_back(entry.second);
    }
    if (!map_poses_corrected) return;
    for (const auto& entry : tracker_placed_truth_) {
      if (!mapper.map().contains(entry.first)) continue;
      const Eigen::Isometry3f move =
          (mapper.map().pose(entry.first) * tracker_poses_.at(entry.first).inverse()).cast<float>();
      for (const Eigen::Vector3f& point : entry.second) map_placed_truth.push_back(move * point);
    }
  });
  const PipelineStats stats = pipeline.stats();

  JsonFields summary;
  summary.add("sequence", quoted(sequence_.dir));
  summary.add("layout", quoted(sequence_.layout));
  summary.add("frames", std::to_string(sequence_.frames.size()));
  summary.add("frames_looked_at", std::to_string(totals.frames_looked_at));
  summary.add("keyframes_picked", std::to_string(totals.keyframes_picked));
  JsonFields refused;
  refused.add("pure_rotation", std::to_string(totals.picking.refused_pure_rotation));
  refused.add("blurred", std::to_string(totals.picking.refused_blurred));
  refused.add("blurred_taken_anyway", std::to_string(totals.picking.blurred_taken_anyway));
  summary.add("keyframes_refused", refused.object());
  summary.add("keyframes_pushed", std::to_string(totals.keyframes_pushed));
  // null for a run that read every keyframe it picked
  summary.add("interrupted_by", totals.interrupted_by.empty() ? "null" : quoted(totals.interrupted_by));
  JsonFields kinds;
  for (const char* kind : {"new", "late", "refined", "source_only", "fused_again", "deferred_fusion"}) {
    kinds.add(kind, std::to_string(kinds_.count(kind) ? kinds_.at(kind) : 0));
  }
  summary.add("results", kinds.object());
  summary.add("backend", quoted(stats.backend));
  summary.add("wall_s", number(totals.wall_s));
  summary.add("image_reading_s", number(totals.reading_s));
  const size_t depth_maps = kinds_.count("new") ? kinds_.at("new") : 0;
  const size_t late = kinds_.count("late") ? kinds_.at("late") : 0;
  summary.add("ms_per_keyframe", number(depth_maps + late ? 1000 * totals.wall_s / (depth_maps + late) : NAN));
  summary.add("median_total_ms", number(median(total_ms_)));
  summary.add("mean_total_ms", number(mean(total_ms_)));
  summary.add("median_estimate_ms", number(median(estimate_ms_)));
  JsonFields pose;
  pose.add("results", std::to_string(pose_refinement_ms_.size()));
  pose.add("median_ms", number(median(pose_refinement_ms_)));
  for (const SourcePoseOutcome outcome : {SourcePoseOutcome::kRefined, SourcePoseOutcome::kConfirmed,
                                          SourcePoseOutcome::kTooFewMatches, SourcePoseOutcome::kRejected}) {
    const char* name = sourcePoseOutcomeName(outcome);
    pose.add(std::string("sources_") + name, std::to_string(pose_outcomes_.count(name) ? pose_outcomes_.at(name) : 0));
  }
  summary.add("pose_refinement", pose.object());
  JsonFields alignment;
  alignment.add("results", std::to_string(direct_alignment_ms_.size()));
  alignment.add("median_ms", number(median(direct_alignment_ms_)));
  for (const SourceAlignmentOutcome outcome :
       {SourceAlignmentOutcome::kAligned, SourceAlignmentOutcome::kNoDepth, SourceAlignmentOutcome::kTooFewPoints,
        SourceAlignmentOutcome::kNotBetter, SourceAlignmentOutcome::kRejected}) {
    const char* name = sourceAlignmentOutcomeName(outcome);
    alignment.add(std::string("sources_") + name,
                  std::to_string(alignment_outcomes_.count(name) ? alignment_outcomes_.at(name) : 0));
  }
  summary.add("direct_alignment", alignment.object());
  JsonFields counters;
  for (const PipelineStatField& field : pipelineStatFields()) counters.add(field.name, std::to_string(stats.*field.value));
  summary.add("stats", counters.object());
  JsonFields writer;
  writer.add("max_queued", std::to_string(options_.writer_queue));
  writer.add("blocked_ms", number(submit_blocked_ms_));
  summary.add("writer", writer.object());

  const DepthComparison pooled = pooledComparison(accuracy_);
  if (accuracy_.empty()) {
    summary.add("depth_accuracy", "null");
  } else {
    JsonFields accuracy = accuracyFields(pooled);
    accuracy.add("depth_maps", std::to_string(accuracy_.size()));
    summary.add("depth_accuracy", accuracy.object());
  }
  const DepthComparison published = pooledPublished(accuracy_, published_accuracy_);
  const bool report_published = publishesWhenFused() && !accuracy_.empty();
  if (!report_published) {
    summary.add("published_depth_accuracy", "null");
  } else {
    JsonFields accuracy = accuracyFields(published);
    accuracy.add("depth_maps", std::to_string(published_accuracy_.size()));
    accuracy.add("confidence_level", number(options_.pipeline.mapper.confidence.min_probability));
    summary.add("published_depth_accuracy", accuracy.object());
  }
  // The weakly textured pixels alone (core/texture.h).
  const DepthComparison weak = pooledComparison(weak_accuracy_);
  const DepthComparison weak_published = pooledPublished(weak_accuracy_, weak_published_accuracy_);
  if (weak_accuracy_.empty()) {
    summary.add("weak_texture", "null");
  } else {
    JsonFields weak_fields;
    weak_fields.add("share_of_truth_pixels_pct", number(100.0 * weak.truth_pixels / std::max(1L, pooled.truth_pixels)));
    weak_fields.add("max_gradient_grey", number(kWeakTextureGradient));
    weak_fields.add("depth_accuracy", accuracyFields(weak).object());
    weak_fields.add("published_depth_accuracy", report_published ? accuracyFields(weak_published).object() : "null");
    summary.add("weak_texture", weak_fields.object());
  }

  JsonFields map;
  std::vector<double> map_within_pct;  // per threshold, when there is ground truth
  std::vector<double> bound_within_pct;  // the same for exact depth at the tracker's poses (true poses known)
  std::vector<double> map_bound_within_pct;  // ... and at the map's corrected poses
  map.add("points", std::to_string(map_points.size()));
  map.add("voxel_size", number(options_.pipeline.mapper.map.leaf_size));
  map.add("min_points_per_voxel", std::to_string(options_.pipeline.mapper.map.min_points_per_voxel));
  if (!pixels_in_map_pct.empty()) {
    map.add("keyframe_pixels_in_map_pct_least", number(*std::min_element(pixels_in_map_pct.begin(), pixels_in_map_pct.end())));
    map.add("keyframe_pixels_in_map_pct_median", number(median(pixels_in_map_pct)));
  }
  if (!truth_points_.empty()) {
    const std::vector<Eigen::Vector3f> truth = allPoints(truth_points_);
    const NearestPointIndex index(truth);
    // Share of `points` within each threshold of the true surface.
    const auto withinPct = [&index](const std::vector<Eigen::Vector3f>& points) {
      std::vector<size_t> within(kMapThresholds.size(), 0);
      for (const Eigen::Vector3f& point : points) {
        const double distance = index.nearestDistance(point, kMapThresholds.back());
        for (size_t i = 0; i < kMapThresholds.size(); ++i) within[i] += distance <= kMapThresholds[i];
      }
      std::vector<double> pct;
      for (size_t count : within) pct.push_back(points.empty() ? NAN : 100.0 * count / points.size());
      return pct;
    };
    map_within_pct = withinPct(map_points);
    addWithinFields(map_within_pct, &map);
    // Share of the true surface with a point of `points` within each threshold.
    const auto coveredPct = [&truth](const std::vector<Eigen::Vector3f>& points) {
      std::vector<size_t> covered(kMapThresholds.size(), 0);
      if (!points.empty()) {
        const NearestPointIndex nearest(points);
        for (const Eigen::Vector3f& point : truth) {
          const double distance = nearest.nearestDistance(point, kMapThresholds.back());
          for (size_t i = 0; i < kMapThresholds.size(); ++i) covered[i] += distance <= kMapThresholds[i];
        }
      }
      std::vector<double> pct;
      for (size_t count : covered) pct.push_back(100.0 * count / truth.size());
      return pct;
    };
    JsonFields covered;
    addWithinFields(coveredPct(map_points), &covered);
    map.add("truth_covered", covered.object());
    if (keptSurface(pipeline.options().mapper).enabled) {
      JsonFields surface, surface_covered;
      surface.add("vertices", std::to_string(mesh.vertices.size()));
      surface.add("triangles", std::to_string(mesh.triangles.size()));
      surface.add("voxel_size", number(pipeline.options().mapper.surface.voxel_size));
      surface.add("blocks", std::to_string(surface_blocks));
      surface.add("memory_mib", number(surface_bytes / 1048576.0));
      addWithinFields(withinPct(mesh.vertices.points), &surface);
      addWithinFields(coveredPct(mesh.vertices.points), &surface_covered);
      surface.add("truth_covered", surface_covered.object());
      summary.add("surface", surface.object());
    }
    map.add("truth_points", std::to_string(truth.size()));
    map.add("truth_at", quoted(tracker_placed_truth_.empty() ? "recorded poses" : "true poses"));
    if (!tracker_placed_truth_.empty()) {
      // The same for the exact depth maps at the tracker's poses: the best a
      // map placed with those poses can do.
      bound_within_pct = withinPct(allPoints(tracker_placed_truth_));
      JsonFields bound_fields;
      addWithinFields(bound_within_pct, &bound_fields);
      map.add("exact_depth_at_tracker_poses", bound_fields.object());
    }
    if (!map_placed_truth.empty()) {
      JsonFields map_bound_fields;
      map_bound_within_pct = withinPct(map_placed_truth);
      addWithinFields(map_bound_within_pct, &map_bound_fields);
      map.add("exact_depth_at_map_poses", map_bound_fields.object());
    }
    // The map after the one similarity (or rigid motion: for a tracker with
    // metric depth, whose scale cannot drift) from its keyframe poses to the
    // true ones: its shape apart from the tracker's gauge (eval/pose_alignment.h).
    const auto aligned = [&](AlignmentKind kind) {
      const PoseAlignment alignment = alignPoses(map_poses, true_poses, kind);
      std::vector<Eigen::Vector3f> moved;
      moved.reserve(map_points.size());
      for (const Eigen::Vector3f& point : map_points) moved.push_back(alignment.apply(point));
      JsonFields fields;
      addWithinFields(withinPct(moved), &fields);
      fields.add("scale", number(alignment.scale));
      fields.add("rotation_deg", number(rotationAngleDeg(alignment.rotation)));
      // What is left of each keyframe pose's error after the alignment.
      std::vector<double> position_mm, rotation_deg;
      for (size_t i = 0; i < map_poses.size(); ++i) {
        const Eigen::Vector3d centre =
            alignment.scale * alignment.rotation * map_poses[i].translation() + alignment.translation;
        const Eigen::Matrix3d rotation = alignment.rotation * map_poses[i].linear();
        position_mm.push_back(1000 * (centre - true_poses[i].translation()).norm());
        rotation_deg.push_back(rotationAngleDeg(rotation.transpose() * true_poses[i].linear()));
      }
      const auto addMedianAndMax = [&fields](const std::string& name, const std::vector<double>& values) {
        fields.add(name + "_median", number(median(values)));
        fields.add(name + "_max", number(*std::max_element(values.begin(), values.end())));
      };
      addMedianAndMax("keyframe_position_error_mm", position_mm);
      addMedianAndMax("keyframe_rotation_error_deg", rotation_deg);
      return fields.object();
    };
    if (map_poses.size() >= 2) {
      map.add("after_similarity_to_true_poses", aligned(AlignmentKind::kSimilarity));
      map.add("after_rigid_alignment_to_true_poses", aligned(AlignmentKind::kRigid));
    }
  }
  summary.add("map", map.object());
  if (keptSurface(pipeline.options().mapper).enabled && truth_points_.empty()) {
    JsonFields surface;
    surface.add("vertices", std::to_string(mesh.vertices.size()));
    surface.add("triangles", std::to_string(mesh.triangles.size()));
    surface.add("blocks", std::to_string(surface_blocks));
    surface.add("memory_mib", number(surface_bytes / 1048576.0));
    summary.add("surface", surface.object());
  }

  char text[512];
  std::snprintf(text, sizeof(text),
                "%zu keyframes of %zu frames (refused: %llu blurred, %llu pure rotations): %zu new, %zu late, %zu refined depth maps (%llu refinements "
                "rejected), %zu fused again with more views, %llu dropped; %.1f s",
                totals.keyframes_picked, totals.frames_looked_at,
                static_cast<unsigned long long>(totals.picking.refused_blurred),
                static_cast<unsigned long long>(totals.picking.refused_pure_rotation), depth_maps, late,
                kinds_.count("refined") ? kinds_.at("refined") : 0,
                static_cast<unsigned long long>(stats.refinements_rejected),
                kinds_.count("fused_again") ? kinds_.at("fused_again") : 0,
                static_cast<unsigned long long>(stats.droppedTotal()), totals.wall_s);
  *line = text;
  if (!totals.interrupted_by.empty()) {
    *line += "; interrupted by " + totals.interrupted_by + " after " + std::to_string(totals.keyframes_pushed) +
             " keyframes pushed";
  }
  if (depth_maps + late > 0) {
    std::snprintf(text, sizeof(text), ", %.0f ms per keyframe (median step %.0f ms, estimate %.0f ms, %s)",
                  1000 * totals.wall_s / (depth_maps + late), median(total_ms_), median(estimate_ms_),
                  stats.backend.c_str());
  } else {
    std::snprintf(text, sizeof(text), ", no depth map (%llu keyframes wait for source views)",
                  static_cast<unsigned long long>(stats.keyframes_waiting_for_sources));
  }
  *line += text;
  if (!accuracy_.empty()) {
    std::snprintf(text, sizeof(text), "; depth within 1/2/5/10 %%: %s %%, completeness %.1f %%",
                  pooled.accuracy.percentages().c_str(), 100 * pooled.completeness());
    *line += text;
  }
  if (report_published) {
    std::snprintf(text, sizeof(text), "; published (confidence >= %.2f): %s %%, completeness %.1f %%",
                  options_.pipeline.mapper.confidence.min_probability, published.accuracy.percentages().c_str(),
                  100 * published.completeness());
    *line += text;
  }
  if (!weak_accuracy_.empty()) {
    std::snprintf(text, sizeof(text), "; weakly textured pixels (%.0f %%): depth within 5 %% %.1f %% (completeness %.1f %%)",
                  100.0 * weak.truth_pixels / std::max(1L, pooled.truth_pixels), 100 * weak.accuracy.fraction(2),
                  100 * weak.completeness());
    *line += text;
    if (report_published) {
      std::snprintf(text, sizeof(text), ", published %.1f %% (completeness %.1f %%)",
                    100 * weak_published.accuracy.fraction(2), 100 * weak_published.completeness());
      *line += text;
    }
  }
  if (!pose_refinement_ms_.empty()) {
    size_t sources = 0;
    for (const auto& entry : pose_outcomes_) sources += entry.second;
    const size_t refined = pose_outcomes_.count("refined") ? pose_outcomes_.at("refined") : 0;
    std::snprintf(text, sizeof(text), "; poses refined for %zu of %zu sources (median %.0f ms)", refined, sources,
                  median(pose_refinement_ms_));
    *line += text;
  }
  std::snprintf(text, sizeof(text), "; map %zu points", map_points.size());
  *line += text;
  for (size_t i = 0; i < map_within_pct.size(); ++i) {
    std::snprintf(text, sizeof(text), ", %.1f %% within %.0f cm", map_within_pct[i], 100 * kMapThresholds[i]);
    *line += text;
  }
  if (!bound_within_pct.empty()) {
    std::snprintf(text, sizeof(text),
                  " of the true surface (exact depth at the tracker's poses: %.1f / %.1f %%", bound_within_pct[0],
                  bound_within_pct.back());
    *line += text;
    if (!map_bound_within_pct.empty()) {
      std::snprintf(text, sizeof(text), ", at the map's poses: %.1f / %.1f %%", map_bound_within_pct[0],
                    map_bound_within_pct.back());
      *line += text;
    }
    *line += ")";
  }
  return summary.object();
}

}  // namespace amhmvs
