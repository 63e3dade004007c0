// amhmvs_map_study: the measurements behind the per-pixel confidence (its
// calibration table, its reliability, the mask level of the published depth)
// and the fusion's thresholds, on a sequence with ground truth. It runs
// amhmvs_map's pipeline (the same options) once per --variant (extra
// amhmvs_map options), every run after the first answered from the first
// one's depth maps (EstimateCache: fusion and confidence change nothing the
// estimator sees), and prints markdown tables (also OUT/study.md) and the
// fitted calibration table (OUT/calibration_fit.txt).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/cloud_metrics.h"
#include "amhmvs_mapping/eval/depth_metrics.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "estimate_cache.h"
#include "keyframe_picker.h"
#include "map_options.h"
#include "tool_main.h"
#include "tool_options.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

const std::string kUsage =
    "Usage: amhmvs_map_study SEQUENCE_DIR OUTPUT_DIR [amhmvs_map options] [study options]\n\n"
    "Runs amhmvs_map's pipeline on a sequence with ground truth (--confidence on, nothing\n"
    "masked) and reports: the raw depth's accuracy; the share of pixels within 5 / 10 % where\n"
    "at least k consistency views agree (the calibration's checks and each --agreement);\n"
    "the calibration table fitted on this run (OUT/calibration_fit.txt); the committed\n"
    "table's reliability (predicted against observed, per bin of confidence); the published\n"
    "depth's accuracy and completeness at each --levels value; and per --variant the map\n"
    "(points, within 2 / 5 cm of the true surface, the share of each keyframe's pixels it holds).\n\n"
    "Study options:\n"
    "  --variant \"OPTIONS\"   extra amhmvs_map options of one more run, e.g.\n"
    "                        \"--fusion_max_relative_depth_difference 0.02\" (repeatable;\n"
    "                        the first run has none)\n"
    "  --levels L1,L2,...    confidence levels of the curve (default 0,0.1,...,0.9)\n"
    "  --agreement PX,REL,DEG  other agreement checks to compare: reprojection error (px),\n"
    "                        relative depth difference, normal angle (deg); 0 = off (repeatable)\n"
    "  --cache DIR           keep the depth maps there (PFM) for later runs of the same study\n";

struct StudyOptions {
  std::vector<std::string> base;                   // amhmvs_map options
  std::vector<std::vector<std::string>> variants;  // first: none
  std::vector<double> levels = {0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9};
  std::vector<FusionOptions> agreements;
  std::string cache;
};

std::vector<double> parseList(const std::string& option, const std::string& text) {
  std::vector<double> values;
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, ',');) values.push_back(parseValue<double>(option, item));
  return values;
}

std::vector<std::string> splitWords(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

StudyOptions parseStudyArguments(const std::vector<std::string>& arguments) {
  StudyOptions study;
  study.variants.push_back({});
  for (size_t i = 0; i < arguments.size(); ++i) {
    const std::string& arg = arguments[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= arguments.size()) throw InputError("option " + arg + " needs a value");
      return arguments[++i];
    };
    if (arg == "--variant") {
      study.variants.push_back(splitWords(value()));
    } else if (arg == "--levels") {
      study.levels = parseList("levels", value());
    } else if (arg == "--agreement") {
      const std::vector<double> v = parseList("agreement", value());
      if (v.size() != 3) throw InputError("option --agreement: expected PX,REL,DEG");
      FusionOptions checks = FusionOptions::reprojection();
      checks.max_reprojection_error = v[0] > 0 ? v[0] : FusionOptions::kOff;
      checks.max_relative_depth_difference = v[1] > 0 ? v[1] : FusionOptions::kOff;
      checks.max_normal_angle_deg = v[2] > 0 ? v[2] : FusionOptions::kOff;
      const std::string problem = checks.validate();
      if (!problem.empty()) throw InputError("option --agreement: " + problem);
      study.agreements.push_back(checks);
    } else if (arg == "--cache") {
      study.cache = value();
    } else {
      study.base.push_back(arg);
    }
  }
  return study;
}

// What a run left of one keyframe: its latest depth map and fusion.
struct KeyframeRecord {
  PinholeCamera camera;
  DepthMap depth;
  bool fused = false;
  PublishedDepth published;                       // confidence at the calibration's checks
  std::vector<AgreementCounts> other_agreements;  // per --agreement
  size_t fused_points = 0;
};

struct RunRecord {
  std::map<int64_t, KeyframeRecord> keyframes;
  std::vector<Eigen::Vector3f> map_points;
  double fusion_ms = 0, confidence_ms = 0;  // summed over the results
  size_t fusions = 0;
};

FusionView viewOf(int local_id, const KeyframeRecord& record) {
  FusionView view;
  view.id = local_id;
  view.camera = record.camera;
  view.depth = record.depth.depth;
  view.normal = record.depth.normal;
  view.cost = record.depth.cost;
  return view;
}

void recordOutput(const KeyframeResult& result, const std::vector<FusionOptions>& agreements, RunRecord* run) {
  run->fusion_ms += result.times.fusion_ms;
  run->confidence_ms += result.times.confidence_ms;
  run->fusions += result.fused.size();
  if (result.has_depth && !result.refinement_rejected) {
    KeyframeRecord& record = run->keyframes[result.id];
    record.camera = result.camera;
    record.depth = result.depth;
  }
  for (const FusedKeyframe& fused : result.fused) {
    KeyframeRecord& record = run->keyframes[fused.id];
    record.fused = true;
    record.published = fused.published;
    record.fused_points = fused.points->size();
    record.other_agreements.clear();
    if (agreements.empty()) continue;
    std::vector<FusionView> views;
    for (int64_t id : fused.consistency_ids) views.push_back(viewOf(static_cast<int>(views.size()), run->keyframes.at(id)));
    const FusionView reference = viewOf(static_cast<int>(views.size()), record);
    for (const FusionOptions& checks : agreements) record.other_agreements.push_back(countAgreement(reference, views, checks));
  }
}

RunRecord runOnce(const std::vector<Keyframe>& keyframes, MapToolOptions options, const std::vector<FusionOptions>& agreements,
                  EstimateCache* cache) {
  options.pipeline.queue_size = std::max<size_t>(1, keyframes.size());
  options.pipeline.mapper.confidence.enabled = true;
  options.pipeline.mapper.confidence.min_probability = 0;  // the study masks by itself
  const MappingPipeline::Log log = [](MappingPipeline::LogLevel level, const std::string& line) {
    if (level == MappingPipeline::LogLevel::kWarn || level == MappingPipeline::LogLevel::kError) std::cerr << "amhmvs_map_study: " << line << "\n";
  };
  MappingPipeline pipeline(options.pipeline, [cache](const DepthProblem& problem) { return cache->estimate(problem); },
                           EstimateFunction(), "cpu", log);
  RunRecord run;
  for (const Keyframe& keyframe : keyframes) {
    pipeline.push(keyframe);
    pipeline.runUntilIdle([&](const PipelineOutput& output) { recordOutput(output.result, agreements, &run); });
  }
  pipeline.withMapper([&](const OnlineMapper& mapper) { run.map_points = mapper.map().exportCloud().points; });
  return run;
}

// Ground truth of the keyframes (depth in each keyframe's camera, the true
// surface in the world), read once.
struct Truth {
  std::map<int64_t, ImageF> depth;
  std::vector<Eigen::Vector3f> surface;
};

Truth readTruth(const PosedSequence& sequence, const RunRecord& run) {
  std::map<int64_t, const PosedFrame*> frames;
  for (const PosedFrame& frame : sequence.frames) frames[frame.id] = &frame;
  Truth truth;
  for (const auto& [id, record] : run.keyframes) {
    const PosedFrame* frame = frames.count(id) ? frames.at(id) : nullptr;
    if (!frame || !frame->ground_truth.present() || record.depth.depth.empty()) continue;
    const DepthMapView view = readGroundTruthDepth(frame->ground_truth, record.camera);
    truth.depth[id] = groundTruthDepthIn(view, frame->ground_truth.registered, record.camera);
    const std::vector<Eigen::Vector3f> points =
        backprojectDepthMaps({trueSurfaceView(view, *frame)}, std::max(1, view.depth.width / 320));
    truth.surface.insert(truth.surface.end(), points.begin(), points.end());
  }
  if (truth.depth.empty()) throw InputError(sequence.dir + ": no ground-truth depth for the keyframes");
  return truth;
}

// Pooled comparison of the keyframes' depth maps, each pixel kept where
// keep(record, index) (a keyframe never fused keeps nothing when !raw).
DepthComparison pooled(const RunRecord& run, const Truth& truth, bool raw,
                       const std::function<bool(const KeyframeRecord&, size_t)>& keep) {
  DepthComparison all;
  for (const auto& [id, image] : truth.depth) {
    const KeyframeRecord& record = run.keyframes.at(id);
    ImageF depth(image.width, image.height, 1, NAN);
    for (size_t i = 0; i < depth.data.size(); ++i) {
      if (raw || (record.fused && keep(record, i))) depth.data[i] = record.depth.depth.data[i];
    }
    all.merge(compareDepth(depth, image));
  }
  return all;
}

std::string row(const std::vector<std::string>& cells) {
  std::string line = "|";
  for (const std::string& cell : cells) line += " " + cell + " |";
  return line + "\n";
}

std::string fixed(double value, int digits = 1) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

std::string accuracyCells(const DepthComparison& c) {
  return fixed(100 * c.accuracy.fraction(0)) + " / " + fixed(100 * c.accuracy.fraction(1)) + " / " +
         fixed(100 * c.accuracy.fraction(2)) + " / " + fixed(100 * c.accuracy.fraction(3));
}

std::string agreementTable(const RunRecord& run, const Truth& truth, const StudyOptions& study) {
  std::ostringstream out;
  out << "\nPixels where at least k consistency views agree (agreement checks: reprojection px, relative depth, "
         "normal deg):\n\n"
      << row({"checks", "k", "completeness %", "within 1 / 2 / 5 / 10 %"}) << row({"---", "---", "---", "---"});
  const auto describe = [](const FusionOptions& c) {
    const auto v = [](float x, int digits) { return std::isinf(x) ? std::string("off") : fixed(x, digits); };
    return v(c.max_reprojection_error, 1) + ", " + v(c.max_relative_depth_difference, 3) + ", " +
           v(c.max_normal_angle_deg, 0);
  };
  for (size_t a = 0; a <= study.agreements.size(); ++a) {
    const FusionOptions& checks = a == 0 ? defaultConfidenceCalibration().checks : study.agreements[a - 1];
    for (int k = 1; k <= 4; ++k) {
      const DepthComparison c = pooled(run, truth, false, [&](const KeyframeRecord& r, size_t i) {
        const AgreementCounts& counts = a == 0 ? r.published.counts : r.other_agreements[a - 1];
        return counts.agreeing.data[i] >= k;
      });
      out << row({describe(checks) + (a == 0 ? " (calibration)" : ""), std::to_string(k),
                  fixed(100 * c.completeness()), accuracyCells(c)});
    }
  }
  return out.str();
}

// Fits the table on the run and checks the committed one against it.
std::string calibrationReport(const RunRecord& run, const Truth& truth, const std::string& out_dir) {
  const ConfidenceCalibration& committed = defaultConfidenceCalibration();
  ConfidenceFit fit(committed);
  constexpr int kBins = 10;
  std::vector<double> predicted(kBins, 0), within5(kBins, 0), within10(kBins, 0), count(kBins, 0);
  for (const auto& [id, image] : truth.depth) {
    const KeyframeRecord& record = run.keyframes.at(id);
    if (!record.fused || record.published.empty()) continue;
    for (size_t i = 0; i < image.data.size(); ++i) {
      const float d = record.depth.depth.data[i], t = image.data[i];
      if (!(std::isfinite(d) && d > 0 && std::isfinite(t) && t > 0)) continue;
      const double error = std::fabs(d - t) / t;
      fit.add(record.published.counts.seen.data[i], record.published.counts.agreeing.data[i],
              record.depth.cost.data[i], error);
      const float p = record.published.confidence.data[i];
      const int bin = std::min(kBins - 1, static_cast<int>(p * kBins));
      predicted[bin] += p;
      within5[bin] += error < 0.05;
      within10[bin] += error < 0.10;
      ++count[bin];
    }
  }
  std::ofstream(out_dir + "/calibration_fit.txt") << calibrationSource(fit);
  std::ostringstream out;
  out << "\nReliability of the committed table (pixels with an estimate and ground truth, fused keyframes):\n\n"
      << row({"confidence", "pixels", "mean predicted %", "observed within 5 %", "observed within 10 %"})
      << row({"---", "---", "---", "---", "---"});
  for (int b = 0; b < kBins; ++b) {
    if (count[b] == 0) continue;
    out << row({fixed(0.1 * b) + "-" + fixed(0.1 * (b + 1)), std::to_string(static_cast<long>(count[b])),
                fixed(100 * predicted[b] / count[b]), fixed(100 * within5[b] / count[b]),
                fixed(100 * within10[b] / count[b])});
  }
  out << "\nThe table fitted on this run: " << out_dir << "/calibration_fit.txt\n";
  return out.str();
}

std::string levelTable(const RunRecord& run, const Truth& truth, const std::vector<double>& levels) {
  std::ostringstream out;
  const DepthComparison raw = pooled(run, truth, true, {});
  out << "\n| published depth | completeness % | within 1 / 2 / 5 / 10 % |\n| --- | --- | --- | --- |\n"
      << row({"raw (every estimate)", fixed(100 * raw.completeness()), accuracyCells(raw)});
  for (double level : levels) {
    const DepthComparison c = pooled(run, truth, false, [level](const KeyframeRecord& r, size_t i) {
      return r.published.confidence.data[i] >= level;
    });
    out << row({"confidence >= " + fixed(level, 2), fixed(100 * c.completeness()), accuracyCells(c)});
  }
  return out.str();
}

// The map against the true surface and the share of each keyframe's pixels
// it holds (fused points / pixels).
std::vector<std::string> mapCells(const RunRecord& run, const Truth& truth) {
  const NearestPointIndex index(truth.surface);
  size_t within2 = 0, within5 = 0;
  for (const Eigen::Vector3f& point : run.map_points) {
    const double distance = index.nearestDistance(point, 0.05);
    within2 += distance <= 0.02;
    within5 += distance <= 0.05;
  }
  std::vector<double> shares;
  for (const auto& [id, record] : run.keyframes) {
    if (record.depth.depth.empty()) continue;
    shares.push_back(static_cast<double>(record.fused_points) / record.depth.depth.pixelCount());
  }
  std::sort(shares.begin(), shares.end());
  const size_t half = std::count_if(shares.begin(), shares.end(), [](double s) { return s >= 0.5; });
  const double n = std::max<size_t>(1, run.map_points.size());
  return {std::to_string(run.map_points.size()), fixed(100 * within2 / n), fixed(100 * within5 / n),
          shares.empty() ? "" : fixed(100 * shares.front()), shares.empty() ? "" : fixed(100 * shares[shares.size() / 2]),
          std::to_string(half) + " of " + std::to_string(shares.size())};
}

int run(const std::vector<std::string>& args) {
  const std::string sequence_dir = args[0], out_dir = args[1];
  const StudyOptions study = parseStudyArguments(std::vector<std::string>(args.begin() + 2, args.end()));
  const MapToolOptions base = parseMapToolArguments(study.base);
  const PosedSequence sequence = readPosedSequence(sequence_dir, base.sequence);
  std::vector<Keyframe> keyframes;
  for (size_t index : pickKeyframes(sequence.frames, base.frames).indices) keyframes.push_back(makeKeyframe(sequence.frames[index], base));
  if (keyframes.empty()) throw InputError(sequence_dir + ": no frame selected");
  std::error_code error;
  fs::create_directories(out_dir, error);
  if (error) throw InputError(out_dir + ": cannot create folder (" + error.message() + ")");
  EstimateCache cache(base.pipeline.estimator, base.pipeline.backend == Backend::kAuto ? Backend::kCpu : base.pipeline.backend,
                      study.cache);

  std::ostringstream report;
  report << "amhmvs_map_study " << sequence_dir << ": " << keyframes.size() << " keyframes\n";
  std::unique_ptr<Truth> truth;
  std::ostringstream variants;
  variants << "\n| fusion variant | map points | within 2 cm % | within 5 cm % | keyframe share in the map: min % | "
              "median % | keyframes >= 50 % |\n| --- | --- | --- | --- | --- | --- | --- |\n";
  for (size_t v = 0; v < study.variants.size(); ++v) {
    std::vector<std::string> arguments = study.base;
    arguments.insert(arguments.end(), study.variants[v].begin(), study.variants[v].end());
    const RunRecord run = runOnce(keyframes, parseMapToolArguments(arguments), v == 0 ? study.agreements : std::vector<FusionOptions>(), &cache);
    if (v == 0) {
      char text[160];
      std::snprintf(text, sizeof(text), "fusion %.1f ms, confidence %.1f ms per fused keyframe (%zu fusions)\n",
                    run.fusion_ms / std::max<size_t>(1, run.fusions), run.confidence_ms / std::max<size_t>(1, run.fusions),
                    run.fusions);
      report << text;
      truth.reset(new Truth(readTruth(sequence, run)));
      report << levelTable(run, *truth, study.levels) << agreementTable(run, *truth, study)
             << calibrationReport(run, *truth, out_dir);
    }
    std::string name;
    for (const std::string& word : study.variants[v]) name += (name.empty() ? "" : " ") + word;
    std::vector<std::string> cells = {name.empty() ? "(base options)" : name};
    for (const std::string& cell : mapCells(run, *truth)) cells.push_back(cell);
    variants << row(cells);
    std::cerr << "amhmvs_map_study: run " << v + 1 << " of " << study.variants.size() << " done (" << cache.misses()
              << " depth maps estimated, " << cache.hits() << " from the cache)\n";
  }
  report << variants.str();
  std::ofstream(out_dir + "/study.md") << report.str();
  std::cout << report.str();
  return 0;
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  const std::string usage = amhmvs::kUsage + "\nThe amhmvs_map options (its --help):\n\n" + amhmvs::mapToolUsage();
  return amhmvs::runToolMain("amhmvs_map_study", usage, argc, argv, 2, true, amhmvs::run);
}
