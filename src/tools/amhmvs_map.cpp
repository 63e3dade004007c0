// amhmvs_map: runs the online mapping pipeline (MappingPipeline) on a
// recorded posed sequence, without ROS. See --help (map_options.cpp).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <thread>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "keyframe_picker.h"
#include "map_options.h"
#include "map_outputs.h"
#include "stop_request.h"
#include "tool_main.h"

namespace amhmvs {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The pipeline's log on stderr; --quiet keeps only warnings and errors.
MappingPipeline::Log stderrLog(bool quiet) {
  return [quiet](MappingPipeline::LogLevel level, const std::string& line) {
    if (level == MappingPipeline::LogLevel::kDebug || (quiet && level == MappingPipeline::LogLevel::kInfo)) return;
    const char* prefix = level == MappingPipeline::LogLevel::kError  ? "error: "
                         : level == MappingPipeline::LogLevel::kWarn ? "warning: "
                                                                     : "";
    std::cerr << "amhmvs_map: " << prefix << line << "\n";
  };
}

// Offline: each keyframe waits for the pipeline (push, then step until idle);
// with depth_filter.enabled so does each frame of the window between it and
// the next keyframe (observe()).
void runOffline(const PosedSequence& sequence, PickedKeyframes* picked, const MapToolOptions& options,
                const StopRequest& stop, MappingPipeline* pipeline, MapOutputs* outputs, MapRunTotals* totals) {
  const auto add = [outputs](const PipelineOutput& output) { outputs->add(output); };
  const bool filter = options.pipeline.mapper.depth_filter.enabled;
  for (size_t k = 0; k < picked->indices.size(); ++k) {
    if (stop.requested()) break;
    const size_t index = picked->indices[k];
    const Clock::time_point read_start = Clock::now();
    Keyframe keyframe = makeKeyframe(sequence.frames[index], options, picked->takeDecoded(index));
    totals->reading_s += secondsSince(read_start);
    pipeline->push(std::move(keyframe));
    ++totals->keyframes_pushed;
    pipeline->runUntilIdle(add);
    const size_t next = k + 1 < picked->indices.size() ? picked->indices[k + 1] : index;
    for (size_t frame = index + options.frames.stride; filter && frame < next && !stop.requested();
         frame += options.frames.stride) {
      const Clock::time_point frame_start = Clock::now();
      Keyframe between = makeKeyframe(sequence.frames[frame], options);
      totals->reading_s += secondsSince(frame_start);
      pipeline->observe(std::move(between));
      pipeline->runUntilIdle(add);
    }
  }
}

// Realtime: a feeder thread pushes keyframes at the recording's stamps
// (scaled by the rate), as a camera would; the pipeline's queue drops the
// oldest when the estimator falls behind.
void runRealtime(const PosedSequence& sequence, PickedKeyframes* picked, const MapToolOptions& options,
                 const StopRequest& stop_request, MappingPipeline* pipeline, MapOutputs* outputs,
                 MapRunTotals* totals) {
  std::atomic<bool> fed{false}, stop{false};
  std::exception_ptr feeder_error;
  double reading_s = 0;
  size_t pushed = 0;
  std::thread feeder([&] {
    try {
      const Clock::time_point start = Clock::now();
      const double first_stamp = sequence.frames[picked->indices.front()].stamp;
      const auto stopping = [&] { return stop || stop_request.requested(); };
      for (size_t index : picked->indices) {
        const double due_s = (sequence.frames[index].stamp - first_stamp) / options.realtime_rate;
        const Clock::time_point due =
            start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(due_s));
        // In steps, so that a stop request is seen while waiting for a late frame.
        while (!stopping() && Clock::now() < due) {
          std::this_thread::sleep_until(std::min(due, Clock::now() + std::chrono::milliseconds(100)));
        }
        if (stopping()) break;
        const Clock::time_point read_start = Clock::now();
        Keyframe keyframe = makeKeyframe(sequence.frames[index], options, picked->takeDecoded(index));
        reading_s += secondsSince(read_start);
        pipeline->push(std::move(keyframe));
        ++pushed;
      }
    } catch (...) {
      feeder_error = std::current_exception();
    }
    fed = true;
    pipeline->wake();
  });
  try {
    while (true) {
      const bool all_fed = fed;  // read before the step: a push after it is seen next round
      const std::vector<PipelineOutput> results = pipeline->step();
      for (const PipelineOutput& output : results) outputs->add(output);
      if (results.empty()) {
        if (all_fed && pipeline->stats().idle) break;
        pipeline->waitForWork(0.1);
      }
    }
  } catch (...) {
    stop = true;  // the feeder ends at its next frame; then the error goes on
    feeder.join();
    throw;
  }
  feeder.join();
  totals->reading_s = reading_s;
  totals->keyframes_pushed = pushed;
  if (feeder_error) std::rethrow_exception(feeder_error);
}

size_t framesLookedAt(size_t frames, const FrameSelection& selection) {
  if (selection.start >= frames) return 0;
  const size_t window = (frames - selection.start + selection.stride - 1) / selection.stride;
  return selection.count > 0 ? std::min(window, selection.count) : window;
}

int run(const std::vector<std::string>& args) {
  const StopRequest stop;  // from here on Ctrl-C still writes the outputs
  const std::string sequence_dir = args[0], output_dir = args[1];
  MapToolOptions options = parseMapToolArguments(std::vector<std::string>(args.begin() + 2, args.end()));
  // max_image_size -1 (auto) needs the backend before the first frame is read.
  options.max_image_size = effectiveMaxImageSize(options.max_image_size, resolvedBackend(options.pipeline.backend));
  const PosedSequence sequence = readPosedSequence(sequence_dir, options.sequence);
  PickedKeyframes picking = pickKeyframes(sequence.frames, options.frames);
  const std::vector<size_t>& picked = picking.indices;
  if (picked.empty()) {
    throw InputError(sequence_dir + ": no frame selected (" + std::to_string(sequence.frames.size()) +
                     " frames; check --start, --count)");
  }
  options.pipeline.queue_size = resolvedQueueSize(options, picked.size());
  MapRunTotals totals;
  totals.frames_looked_at = framesLookedAt(sequence.frames.size(), options.frames);
  totals.keyframes_picked = picked.size();
  totals.picking = picking.stats;

  MappingPipeline pipeline(options.pipeline, stderrLog(options.quiet));
  if (!options.quiet) {
    std::fprintf(stderr,
                 "amhmvs_map: %s sequence, %zu frames, %zu looked at, %zu keyframes; backend %s; %s\n",
                 sequence.layout.c_str(), sequence.frames.size(), totals.frames_looked_at, picked.size(),
                 backendName(pipeline.backend()),
                 options.realtime_rate > 0 ? "realtime replay" : "offline (every keyframe waits)");
  }
  MapOutputs outputs(output_dir, options, sequence);
  const Clock::time_point start = Clock::now();
  if (options.realtime_rate > 0) {
    runRealtime(sequence, &picking, options, stop, &pipeline, &outputs, &totals);
  } else {
    runOffline(sequence, &picking, options, stop, &pipeline, &outputs, &totals);
  }
  totals.wall_s = secondsSince(start);
  totals.interrupted_by = stop.signalName();
  const std::string summary = outputs.finish(pipeline, totals);
  std::cerr << "amhmvs_map: " << summary << "\n";  // also with --quiet: one line
  std::cout << "amhmvs_map: wrote " << output_dir << "\n";
  return stop.requested() ? stop.exitCode() : 0;
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  // --print_parameters yaml|markdown: config/mapping.yaml or docs/parameters.md, no sequence needed.
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) != "--print_parameters") continue;
    const std::string format = i + 1 < argc ? argv[i + 1] : "";
    if (format != "yaml" && format != "markdown") {
      std::cerr << "amhmvs_map: error: option --print_parameters: '" << format << "' is not yaml or markdown\n";
      return 1;
    }
    std::cout << (format == "yaml" ? amhmvs::mappingParametersYaml() : amhmvs::mappingParametersMarkdown());
    return 0;
  }
  return amhmvs::runToolMain("amhmvs_map", amhmvs::mapToolUsage(), argc, argv, 2, true, amhmvs::run);
}
