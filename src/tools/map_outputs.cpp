#include "map_outputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <numeric>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/io/colormap.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/map_export.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

// The stage times by name, in the order of the logs.
const std::vector<std::pair<const char*, double StageTimes::*>>& stageFields() {
  static const std::vector<std::pair<const char*, double StageTimes::*>> fields = {
      {"queue_wait_ms", &StageTimes::queue_wait_ms}, {"selection_ms", &StageTimes::selection_ms},
      {"depth_range_ms", &StageTimes::depth_range_ms}, {"problem_ms", &StageTimes::problem_ms},
      {"estimate_ms", &StageTimes::estimate_ms},     {"fusion_ms", &StageTimes::fusion_ms},
      {"map_ms", &StageTimes::map_ms},               {"total_ms", &StageTimes::total_ms}};
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

}  // namespace

struct MapOutputs::Row {
  size_t index = 0;  // results so far, 1-based
  PipelineOutput output;
};

MapOutputs::MapOutputs(const std::string& dir, const MapToolOptions& options, const PosedSequence& sequence)
    : dir_(dir), options_(options), sequence_(sequence), writer_(options.writer_queue) {
  for (size_t i = 0; i < sequence.frames.size(); ++i) frame_of_id_[sequence.frames[i].id] = i;
  std::error_code error;
  for (const char* sub : {"", "/depth", "/clouds", "/previews"}) {
    if (std::string(sub) == "/depth" && !options.write_depth) continue;
    if (std::string(sub) == "/clouds" && !options.write_clouds) continue;
    if (std::string(sub) == "/previews" && !options.write_previews) continue;
    fs::create_directories(dir + sub, error);
    if (error) throw InputError(dir + sub + ": cannot create folder (" + error.message() + ")");
  }
  csv_ = openLog(dir + "/keyframes.csv");
  jsonl_ = openLog(dir + "/keyframes.jsonl");
  std::fprintf(csv_, "id,frame,stamp,kind,sources,depth_min,depth_max,depth_range_source,width,height,backend");
  for (const auto& field : stageFields()) std::fprintf(csv_, ",%s", field.first);
  std::fprintf(csv_, ",estimator_ms,fused_ids,fused_points");
  for (const char* column : kAccuracyColumns) std::fprintf(csv_, ",%s", column);
  std::fprintf(csv_, ",completeness_pct,truth_pixels\n");
}

MapOutputs::~MapOutputs() {
  if (csv_) std::fclose(csv_);
  if (jsonl_) std::fclose(jsonl_);
}

void MapOutputs::add(const PipelineOutput& output) {
  auto row = std::make_shared<Row>();
  row->index = ++results_;
  row->output = output;
  writer_.post([this, row] { write(*row); });
}

void MapOutputs::write(const Row& row) {
  const KeyframeResult& result = row.output.result;
  const auto frame_it = frame_of_id_.find(result.id);
  const PosedFrame* frame = frame_it == frame_of_id_.end() ? nullptr : &sequence_.frames[frame_it->second];
  const std::string name = id6(result.id);
  const char* kind = kindOf(result);
  ++kinds_[kind];

  // Files of this result.
  if (result.has_depth && options_.write_depth) writePfm(dir_ + "/depth/" + name + ".pfm", result.depth.depth);
  if (result.has_depth && options_.write_previews) {
    std::pair<float, float> range(static_cast<float>(result.depth_range.min), static_cast<float>(result.depth_range.max));
    try {
      range = robustRange(result.depth.depth);
    } catch (const InputError&) {  // no valid depth: the estimate's range
    }
    writePng(dir_ + "/previews/" + name + ".png", colorizeDepth(result.depth.depth, range.first, range.second));
  }
  size_t fused_points = 0;
  std::string fused_ids, fused_array;  // "1 2" for CSV and people, "1, 2" for JSON
  for (const FusedKeyframe& fused : result.fused) {
    fused_points += fused.points.size();
    fused_ids += (fused_ids.empty() ? "" : " ") + std::to_string(fused.id);
    fused_array += (fused_array.empty() ? "" : ", ") + std::to_string(fused.id);
    if (options_.write_clouds) {
      writePly(dir_ + "/clouds/" + id6(fused.id) + ".ply", keyframeWorldCloud(fused.points, cameraToWorld(fused.camera)));
    }
  }

  // Accuracy against the recording's ground truth (report only).
  bool has_truth = false;
  DepthComparison comparison;
  if (result.has_depth && frame && frame->ground_truth.present()) {
    const DepthMapView truth = readGroundTruthDepth(frame->ground_truth, result.camera);
    comparison = compareDepth(result.depth.depth, groundTruthDepthIn(truth, frame->ground_truth.registered, result.camera));
    accuracy_[result.id] = comparison;
    if (!truth_points_.count(result.id)) truth_points_[result.id] = backprojectDepthMaps({truth}, std::max(1, truth.depth.width / kTruthSurfaceColumns));
    has_truth = true;
  }
  if (result.has_depth) {
    total_ms_.push_back(result.times.total_ms);
    estimate_ms_.push_back(result.times.estimate_ms);
  }

  // keyframes.csv and keyframes.jsonl
  std::string sources;
  std::string source_array;
  for (int64_t id : result.selection.source_ids) {
    sources += (sources.empty() ? "" : " ") + std::to_string(id);
    source_array += (source_array.empty() ? "" : ", ") + std::to_string(id);
  }
  const std::string range_source = result.has_depth ? depthRangeSourceName(result.depth_range.source) : "";
  const double depth_min = result.has_depth ? result.depth_range.min : NAN;
  const double depth_max = result.has_depth ? result.depth_range.max : NAN;
  const std::string backend = result.has_depth ? backendName(result.depth.backend) : "";
  const std::string frame_name = frame ? frame->name : "";
  const double stamp = frame ? frame->stamp : NAN;
  auto csvNumber = [](double v) { return std::isfinite(v) ? number(v) : std::string(); };
  std::fprintf(csv_, "%lld,%s,%s,%s,%s,%s,%s,%s,%d,%d,%s", static_cast<long long>(result.id), frame_name.c_str(),
               csvNumber(stamp).c_str(), kind, sources.c_str(), csvNumber(depth_min).c_str(),
               csvNumber(depth_max).c_str(), range_source.c_str(), result.camera.width, result.camera.height,
               backend.c_str());
  JsonFields json;
  json.add("id", std::to_string(result.id));
  json.add("frame", quoted(frame_name));
  json.add("stamp", number(stamp));
  json.add("kind", quoted(kind));
  json.add("sources", "[" + source_array + "]");
  json.add("depth_min", number(depth_min));
  json.add("depth_max", number(depth_max));
  json.add("depth_range_source", result.has_depth ? quoted(range_source) : "null");
  json.add("width", std::to_string(result.camera.width));
  json.add("height", std::to_string(result.camera.height));
  json.add("backend", result.has_depth ? quoted(backend) : "null");
  JsonFields times;
  for (const auto& field : stageFields()) {
    std::fprintf(csv_, ",%s", number(result.times.*field.second).c_str());
    times.add(field.first, number(result.times.*field.second));
  }
  const double estimator_ms = result.has_depth ? result.depth.milliseconds : NAN;
  std::fprintf(csv_, ",%s,%s,%zu", csvNumber(estimator_ms).c_str(), fused_ids.c_str(), fused_points);
  json.add("times", times.object());
  json.add("estimator_ms", number(estimator_ms));
  json.add("fused_ids", "[" + fused_array + "]");
  json.add("fused_points", std::to_string(fused_points));
  for (size_t i = 0; i < kAccuracyColumns.size(); ++i) {
    std::fprintf(csv_, ",%s", has_truth ? number(100.0 * comparison.accuracy.fraction(i)).c_str() : "");
  }
  std::fprintf(csv_, ",%s,%s\n", has_truth ? number(100.0 * comparison.completeness()).c_str() : "",
               has_truth ? std::to_string(comparison.truth_pixels).c_str() : "");
  json.add("accuracy", has_truth ? accuracyFields(comparison).object() : "null");
  std::fprintf(jsonl_, "%s\n", json.object().c_str());
  std::fflush(csv_);
  std::fflush(jsonl_);

  if (options_.quiet) return;
  std::ostringstream line;
  line << "[" << row.index << "] keyframe " << result.id << " " << frame_name << ": " << kind;
  if (result.has_depth) {
    char text[160];
    std::snprintf(text, sizeof(text), ", %zu sources, depth %.2f-%.2f m (%s), %.0f ms (estimate %.0f)",
                  result.selection.source_ids.size(), depth_min, depth_max, range_source.c_str(),
                  result.times.total_ms, result.times.estimate_ms);
    line << text;
  }
  if (!fused_ids.empty()) line << ", fused " << fused_ids;
  if (has_truth) {
    char text[96];
    std::snprintf(text, sizeof(text), ", within 5/10 %%: %.1f/%.1f %%, complete %.0f %%",
                  100 * comparison.accuracy.fraction(2), 100 * comparison.accuracy.fraction(3),
                  100 * comparison.completeness());
    line << text;
  }
  std::cerr << line.str() << "\n";
}

std::string MapOutputs::finish(const MappingPipeline& pipeline, const MapRunTotals& totals) {
  writer_.finish();
  std::fflush(csv_);
  std::fflush(jsonl_);
  std::string line;
  const std::string summary = summaryJson(pipeline, totals, &line);
  std::FILE* file = openLog(dir_ + "/summary.json");
  std::fprintf(file, "%s\n", summary.c_str());
  std::fclose(file);
  return line;
}

std::string MapOutputs::summaryJson(const MappingPipeline& pipeline, const MapRunTotals& totals,
                                    std::string* line) {
  // The map: written, and judged against the ground-truth surface.
  std::vector<Eigen::Vector3f> map_points;
  pipeline.withMapper([&](const OnlineMapper& mapper) {
    writeMap(dir_ + "/map.ply", mapper.map());
    map_points = mapper.map().exportCloud().points;
  });
  const PipelineStats stats = pipeline.stats();

  JsonFields summary;
  summary.add("sequence", quoted(sequence_.dir));
  summary.add("layout", quoted(sequence_.layout));
  summary.add("frames", std::to_string(sequence_.frames.size()));
  summary.add("frames_looked_at", std::to_string(totals.frames_looked_at));
  summary.add("keyframes_picked", std::to_string(totals.keyframes_picked));
  summary.add("keyframes_pushed", std::to_string(totals.keyframes_pushed));
  JsonFields kinds;
  for (const char* kind : {"new", "late", "refined", "source_only"}) {
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
  JsonFields counters;
  for (const PipelineStatField& field : pipelineStatFields()) counters.add(field.name, std::to_string(stats.*field.value));
  summary.add("stats", counters.object());
  JsonFields writer;
  writer.add("max_queued", std::to_string(writer_.maxQueued()));
  writer.add("peak_queued", std::to_string(writer_.peakQueued()));
  writer.add("blocked_ms", number(writer_.blockedMilliseconds()));
  summary.add("writer", writer.object());

  DepthComparison pooled;
  for (const auto& entry : accuracy_) pooled.merge(entry.second);
  if (accuracy_.empty()) {
    summary.add("depth_accuracy", "null");
  } else {
    JsonFields accuracy = accuracyFields(pooled);
    accuracy.add("depth_maps", std::to_string(accuracy_.size()));
    summary.add("depth_accuracy", accuracy.object());
  }

  JsonFields map;
  std::vector<double> map_within_pct;  // per threshold, when there is ground truth
  map.add("points", std::to_string(map_points.size()));
  map.add("voxel_size", number(options_.pipeline.mapper.map.leaf_size));
  if (!truth_points_.empty()) {
    std::vector<Eigen::Vector3f> truth;
    for (const auto& entry : truth_points_) truth.insert(truth.end(), entry.second.begin(), entry.second.end());
    const VoxelGridIndex index(truth, kMapThresholds.back());
    std::vector<size_t> within(kMapThresholds.size(), 0);
    for (const Eigen::Vector3f& point : map_points) {
      const double distance = index.nearestDistance(point, kMapThresholds.back());
      for (size_t i = 0; i < kMapThresholds.size(); ++i) within[i] += distance <= kMapThresholds[i];
    }
    for (size_t i = 0; i < kMapThresholds.size(); ++i) {
      map_within_pct.push_back(map_points.empty() ? NAN : 100.0 * within[i] / map_points.size());
      map.add("within_" + number(100 * kMapThresholds[i]) + "cm_pct", number(map_within_pct.back()));
    }
    map.add("truth_points", std::to_string(truth.size()));
  }
  summary.add("map", map.object());

  char text[512];
  std::snprintf(text, sizeof(text),
                "%zu keyframes of %zu frames: %zu new, %zu late, %zu refined depth maps, %llu dropped; "
                "%.1f s, %.0f ms per keyframe (median step %.0f ms, estimate %.0f ms, %s)",
                totals.keyframes_picked, totals.frames_looked_at, depth_maps, late,
                kinds_.count("refined") ? kinds_.at("refined") : 0, static_cast<unsigned long long>(stats.droppedTotal()),
                totals.wall_s, depth_maps + late ? 1000 * totals.wall_s / (depth_maps + late) : 0.0,
                median(total_ms_), median(estimate_ms_), stats.backend.c_str());
  *line = text;
  if (!accuracy_.empty()) {
    std::snprintf(text, sizeof(text), "; depth within 1/2/5/10 %%: %s %%, completeness %.1f %%",
                  pooled.accuracy.percentages().c_str(), 100 * pooled.completeness());
    *line += text;
  }
  std::snprintf(text, sizeof(text), "; map %zu points", map_points.size());
  *line += text;
  for (size_t i = 0; i < map_within_pct.size(); ++i) {
    std::snprintf(text, sizeof(text), ", %.1f %% within %.0f cm", map_within_pct[i], 100 * kMapThresholds[i]);
    *line += text;
  }
  return summary.object();
}

}  // namespace amhmvs
