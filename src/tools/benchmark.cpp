// amhmvs_benchmark: time per depth map on real and synthetic scenes.
//
// GPU times are CUDA-event times inside the estimator, medians of --runs runs
// after one warm-up: "ms" from the images in device memory to depth, normal
// and cost in host memory (kernels and download), "with upload ms" from the
// images in host memory. CPU times use steady_clock with the given thread
// count (both columns equal).
//
// usage: amhmvs_benchmark [DATA_DIR] [--out FILE] [--runs N] [--cpu-threads N] [--quick]
//                         [--only SCENE[,SCENE...]]  (fountain_x0.25 ... fountain_x1,
//                                           synthetic, scaling, cpu, multiscale, cpu-scaling,
//                                           fusion, map, pipeline, store, replay, pose)
//                         [--replay N]     keyframes of the memory replay (10000)
//                         [--map-foreground] the replay updates the voxel map in its own thread
//                         [--pipeline-multiscale N[,K]] the pipeline's estimator at N scales,
//                                           K iterations at the finer ones (default: the
//                                           product's 2,1; 1: the paper's single scale); the replay too
//
// Online pipeline tables (MappingPipeline, GPU when usable):
//   fusion:   fuseDepthMaps (CPU, OpenMP, all cores) of a 640x480 keyframe
//             against 4 and 8 views (true depth of the room scene);
//   map:      VoxelMap::addKeyframe alone, 640x480 keyframes of true points;
//   pipeline: a 640x480 room sequence, push + step per keyframe, with 4 and 8
//             sources: keyframes per second end to end and the median stages;
//   store:    1100 keyframes of 160x120 (80x60 without a GPU), every one kept:
//             the per-keyframe stages and the idle step at 50, 200, 500 and
//             1000 stored keyframes (must stay flat);
//   replay:   N keyframes of 160x120 through one pipeline; host RSS and
//             device memory every N/10 keyframes (must stay flat).
// The scaling rows time the synthetic scene at 4 sizes x 3 source counts; the
// cpu rows the CPU backend at 320x240 and 640x480 (4 sources, --cpu-threads),
// the cpu-scaling rows 320x240 at 1, 2, 4 and 8 threads (up to the core count);
// pose: the pose refinement before stereo (pose_refinement_benchmark.h) and
//       the map corrections for real trackers (map_correction_benchmark.h).
// the multiscale rows the coarse-to-fine driver as the product runs it (2
// scales, 1 iteration at the finer) at 640x480 (GPU) and 320x240 (CPU), 4 sources.
// DATA_DIR holds mvsnet/fountain_x0.25, fountain_x0.5, fountain_x1 dense
// folders with decodable images (see scripts/gpu_machine/prepare_gpu_data.py); rows whose
// folder is missing are skipped.
#include <sys/stat.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#ifdef AMHMVS_WITH_CUDA
#include <cuda_runtime.h>
#endif

#include "amhmvs_mapping/core/stopwatch.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/depth_map_fuser.h"
#include "amhmvs_mapping/mapping/fusion.h"
#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "depth_job.h"
#include "map_correction_benchmark.h"
#include "pose_refinement_benchmark.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

struct Row {
  std::string scene;
  int width, height, sources, iterations;
  Backend backend;
  int threads;
  double median_ms, min_ms;  // images in device memory -> results in host memory
  double median_total_ms;     // images in host memory -> results in host memory
  double gpu_mib;
};

bool exists(const std::string& path) {
  struct stat info;
  return stat(path.c_str(), &info) == 0;
}

Row measure(const std::string& scene, const DepthProblem& problem, Backend backend,
            int iterations, int runs, int threads, PatchMatchOptions options = PatchMatchOptions()) {
#ifdef _OPENMP
  if (backend == Backend::kCpu) omp_set_num_threads(threads);
#endif
  options.num_iterations = iterations;
  const DepthEstimator estimator(options, backend);
  estimator.estimate(problem);  // warm-up: module load, allocation paths
  std::vector<double> times, totals;
  double gpu_mib = 0;
  for (int r = 0; r < runs; ++r) {
    const DepthMap map = estimator.estimate(problem);
    times.push_back(map.compute_milliseconds);
    totals.push_back(map.milliseconds);
    gpu_mib = std::max(gpu_mib, map.gpu_memory_bytes / (1024.0 * 1024.0));
  }
  std::sort(times.begin(), times.end());
  std::sort(totals.begin(), totals.end());
  return {scene, problem.reference_camera.width, problem.reference_camera.height,
          static_cast<int>(problem.source_cameras.size()), iterations, backend,
          backend == Backend::kCpu ? threads : 0, times[times.size() / 2], times.front(),
          totals[totals.size() / 2], gpu_mib};
}

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// Resident set of this process (MiB).
double hostRssMib() {
  long pages_total = 0, pages_resident = 0;
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  if (std::fscanf(f, "%ld %ld", &pages_total, &pages_resident) != 2) pages_resident = 0;
  std::fclose(f);
  return pages_resident * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1 << 20);
}

// Device memory in use on the GPU (all processes; MiB); 0 without CUDA.
double deviceUsedMib() {
#ifdef AMHMVS_WITH_CUDA
  size_t free_bytes = 0, total = 0;
  if (cudaMemGetInfo(&free_bytes, &total) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return (total - free_bytes) / 1048576.0;
#else
  return 0;
#endif
}

std::string cacheSummary(const DeviceCacheStats& stats) {
  char text[160];
  std::snprintf(text, sizeof(text), "%lu / %lu / %lu", static_cast<unsigned long>(stats.uploads),
                static_cast<unsigned long>(stats.hits), static_cast<unsigned long>(stats.evictions));
  return text;
}

// Rendered keyframes of the room scene along its smooth trajectory.
std::vector<Keyframe> roomKeyframes(int count, int width, int height, uint32_t seed) {
  const SyntheticWorld world = makeIndoorRoomWorld(seed);
  const std::vector<PinholeCamera> cameras = makeSmoothTrajectory(count, width, height, seed);
  std::vector<Keyframe> keyframes;
  for (int i = 0; i < count; ++i) {
    RenderedView view = renderView(world, cameras[i], 1);
    Keyframe keyframe;
    keyframe.id = i;
    keyframe.stamp = 0.1 * i;
    keyframe.image = toGray(view.image);
    keyframe.camera = view.camera;
    float lo = 1e9f, hi = 0;
    for (float d : view.depth.data) {
      if (std::isfinite(d)) {
        lo = std::min(lo, d);
        hi = std::max(hi, d);
      }
    }
    keyframe.depth_min = 0.9 * lo;  // as a SLAM front end's sparse depth range would give
    keyframe.depth_max = 1.1 * hi;
    keyframes.push_back(std::move(keyframe));
  }
  return keyframes;
}

// One 640x480 keyframe fused against `views` others (the true depth and
// normals of the room scene), median of `runs` after a warm-up: on the CPU
// (fuseDepthMaps) and, where there is a GPU, with DepthMapFuser as the
// mapper uses it (the consistency views' maps resident, the reference's
// uploaded once per keyframe: a new key every run). Wall clock, upload,
// kernel, compaction and download included.
std::string fusionTable(int runs) {
  std::ostringstream out;
  int threads = 1;
#ifdef _OPENMP
  threads = omp_get_max_threads();
#endif
  out << "\n## Fusion, 640x480 keyframe, room scene (CPU: " << threads << " OpenMP threads)\n\n"
      << "| backend | consistency views | median ms | min ms | points |\n|---|---|---|---|---|\n";
  const SyntheticWorld world = makeIndoorRoomWorld(1);
  const std::vector<PinholeCamera> cameras = makeSmoothTrajectory(9, 640, 480, 1);
  std::vector<RenderedView> rendered;  // owns the images the fusion views borrow
  for (int i = 0; i < 9; ++i) rendered.push_back(renderView(world, cameras[i], 1));
  std::vector<FusionView> all;
  for (int i = 0; i < 9; ++i) {
    FusionView fusion;
    fusion.id = i;
    fusion.camera = rendered[i].camera;
    fusion.depth = rendered[i].depth;
    fusion.normal = rendered[i].normal;
    fusion.color = rendered[i].image;
    fusion.key = i;
    all.push_back(std::move(fusion));
  }
  std::unique_ptr<DepthMapFuser> gpu;
  if (cudaBackendAvailable(nullptr)) gpu.reset(new DepthMapFuser(Backend::kCuda));
  int64_t next_key = 1000;
  for (Backend backend : {Backend::kCpu, Backend::kCuda}) {
    if (backend == Backend::kCuda && !gpu) continue;
    for (int sources : {4, 8}) {
      // Only the reference keyframe is fused (the others have no sources), as
      // the mapper fuses one keyframe against its consistency views.
      std::vector<FusionView> views(all.begin(), all.begin() + sources + 1);
      for (int j = 1; j <= sources; ++j) views[0].source_ids.push_back(j);
      const FusionOptions options = FusionOptions::reprojection();
      const auto fuse = [&]() {
        views[0].key = next_key++;
        return backend == Backend::kCuda ? gpu->fuse(views, options) : fuseDepthMaps(views, options);
      };
      fuse();  // warm-up
      std::vector<double> times;
      size_t points = 0;
      for (int r = 0; r < runs; ++r) {
        const auto start = std::chrono::steady_clock::now();
        const FusionResult result = fuse();
        times.push_back(millisecondsSince(start));
        points = result.pointCount();
      }
      char line[200];
      std::snprintf(line, sizeof(line), "| %s | %d | %.2f | %.2f | %zu |\n", backendName(backend), sources,
                    median(times), *std::min_element(times.begin(), times.end()), points);
      out << line;
      std::fprintf(stderr, "%s", line);  // progress: visible if the run is cut short
    }
  }
  return out.str();
}

// The voxel-map update alone (VoxelMap::addKeyframe in the caller's thread,
// all cores): `count` 640x480 keyframes of the room scene along its
// trajectory, each pixel with a true depth one point (camera frame, about
// 300,000 per keyframe: more than fusion keeps), median and largest ms.
std::string mapTable(int count) {
  const SyntheticWorld world = makeIndoorRoomWorld(1);
  const std::vector<PinholeCamera> cameras = makeSmoothTrajectory(count, 640, 480, 1);
  std::vector<Shared<KeyframePoints>> keyframes;
  size_t total = 0;
  for (const PinholeCamera& camera : cameras) {
    const RenderedView view = renderView(world, camera, 1);
    KeyframePoints points;
    for (int y = 0; y < view.depth.height; ++y) {
      for (int x = 0; x < view.depth.width; ++x) {
        const float z = view.depth.at(x, y);
        if (!std::isfinite(z)) continue;
        KeyframePoint point;
        point.position = camera.backproject(x, y, z).cast<float>();
        point.normal = Eigen::Vector3f(view.normal.at(x, y, 0), view.normal.at(x, y, 1), view.normal.at(x, y, 2));
        for (int c = 0; c < 3; ++c) point.rgb[c] = view.image.at(x, y, c);
        points.push_back(point);
      }
    }
    total += points.size();
    keyframes.emplace_back(std::move(points));
  }
  VoxelMapOptions options;
  options.leaf_size = 0.02;
  VoxelMap map(options);
  std::vector<double> times;
  for (int i = 0; i < count; ++i) {
    const auto start = std::chrono::steady_clock::now();
    map.addKeyframe(i, cameraToWorld(cameras[i]), keyframes[i]);
    times.push_back(millisecondsSince(start));
  }
  std::ostringstream out;
  char line[300];
  std::snprintf(line, sizeof(line),
                "\n## Voxel-map update alone, %d keyframes of 640x480 (room, every pixel a point: %.0f per keyframe)\n\n"
                "| median ms | largest ms | voxels at the end |\n|---|---|---|\n| %.2f | %.2f | %zu |\n",
                count, static_cast<double>(total) / count, median(times), *std::max_element(times.begin(), times.end()),
                map.voxelCount());
  out << line;
  std::fprintf(stderr, "%s", line);
  return out.str();
}

// Coarse-to-fine settings of the pipeline table's estimator.
struct Multiscale {
  // The product's (MappingParameters: two scales, one iteration at the finer).
  int levels = MappingParameters().pipeline.estimator.multiscale_levels;
  int iterations = MappingParameters().pipeline.estimator.multiscale_iterations;
};

PipelineOptions pipelineOptions(int sources, Multiscale multiscale = Multiscale()) {
  PipelineOptions options;
  options.estimator.multiscale_levels = multiscale.levels;
  options.estimator.multiscale_iterations = multiscale.iterations;
  options.mapper.sources.max_sources = sources;
  options.mapper.map.leaf_size = 0.02;
  options.queue_size = 4;
  return options;
}

// The online pipeline on a 640x480 room sequence: push one keyframe, one
// step() (sustained camera-rate input, serial: what one GPU does).
std::string pipelineTable(int keyframe_count, Multiscale multiscale) {
  std::ostringstream out;
  out << "\n## Online pipeline (MappingPipeline), 640x480 room sequence, " << keyframe_count
      << " keyframes, 6 iterations";
  if (multiscale.levels > 1) {
    out << ", " << multiscale.levels << " scales (" << multiscale.iterations << " iterations at the finer ones)";
  }
  out << "\n\n"
      << "Wall clock per keyframe: push() of the next keyframe and the step() that processes this one (the "
         "next keyframe waits meanwhile, as in a camera-rate stream: refinements, which only run when the queue "
         "is empty, do not); stages are medians over the keyframes "
         "with a depth map (estimate: the estimator's wall time; fusion and map: the fusions and map updates "
         "this keyframe's step did; with a GPU estimator a keyframe is fused during the next one's estimate: "
         "'during the estimate' is that fusion's wall time, inside the estimate, its parts in store, fusion, "
         "confidence and map).\n\n"
      << "| sources | estimate / fusion backend | keyframes/s | median total ms | selection | depth range | problem | estimate "
         "| (estimator's own) | store | fusion | confidence | map (waiting for it) | during the estimate | map update (background) | rest | device images: uploads / hits / evictions "
         "| fused maps: uploads (of them copied on the GPU) / hits |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  const std::vector<Keyframe> keyframes = roomKeyframes(keyframe_count, 640, 480, 1);
  std::string splits;  // after the table
  for (int sources : {4, 8}) {
    MappingPipeline pipeline(pipelineOptions(sources, multiscale));
    std::vector<double> totals, selection, range, problem, estimate, own, store, fusion, confidence, map, overlapped,
        rest, map_background;
    const auto start = std::chrono::steady_clock::now();
    // A camera-rate stream keeps the next keyframe waiting while one is
    // processed: push keyframe k + 1, then step() (which processes keyframe
    // k). Refinements, which run only when no keyframe waits, do not run.
    pipeline.push(keyframes.front());
    for (size_t k = 0; k < keyframes.size(); ++k) {
      const Keyframe& keyframe = keyframes[k];
      const auto pushed = std::chrono::steady_clock::now();
      if (k + 1 < keyframes.size()) pipeline.push(keyframes[k + 1]);
      double stored = 0, fused = 0, confident = 0, mapped = 0;
      const StageTimes* times = nullptr;
      // One step per keyframe: the keyframe (and a late one if due).
      const std::vector<PipelineOutput> outputs = pipeline.step();
      for (const PipelineOutput& output : outputs) {
        stored += output.result.times.store_ms;
        fused += output.result.times.fusion_ms;
        confident += output.result.times.confidence_ms;
        mapped += output.result.times.map_ms;
        if (output.result.id == keyframe.id && output.result.has_depth) times = &output.result.times;
      }
      const double total = millisecondsSince(pushed);
      totals.push_back(total);
      map_background.push_back(pipeline.stats().last_map_update_ms);
      if (!times) continue;
      selection.push_back(times->selection_ms);
      range.push_back(times->depth_range_ms);
      problem.push_back(times->problem_ms);
      estimate.push_back(times->estimate_ms);
      for (const PipelineOutput& output : outputs) {
        if (output.result.id == keyframe.id && output.result.has_depth) own.push_back(output.result.depth->milliseconds);
      }
      store.push_back(stored);
      fusion.push_back(fused);
      confidence.push_back(confident);
      map.push_back(mapped);
      overlapped.push_back(times->fused_during_estimate_ms);
      rest.push_back(total - times->selection_ms - times->depth_range_ms - times->problem_ms - times->estimate_ms -
                     stored - fused - confident - mapped + times->fused_during_estimate_ms);
    }
    const double seconds = millisecondsSince(start) / 1000.0;
    const PipelineStats stats = pipeline.stats();
    const FuserCacheStats fused_maps = pipeline.fusionCacheStats();
    char line[500];
    std::snprintf(line, sizeof(line),
                  "| %d | %s | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s | %lu (%lu) / %lu |\n", sources,
                  (stats.backend + " / " + backendName(pipeline.fusionBackend())).c_str(), keyframes.size() / seconds, median(totals), median(selection), median(range),
                  median(problem), median(estimate), median(own), median(store), median(fusion), median(confidence), median(map), median(overlapped), median(map_background), median(rest),
                  cacheSummary(pipeline.deviceCacheStats()).c_str(), static_cast<unsigned long>(fused_maps.uploads),
                  static_cast<unsigned long>(fused_maps.device_copies), static_cast<unsigned long>(fused_maps.hits));
    out << line;
    std::fprintf(stderr, "%s", line);  // progress: visible if the run is cut short
    const FuserTimes fuser = pipeline.fusionTimes();
    if (fuser.references > 0) {
      const double n = static_cast<double>(fuser.references);
      std::snprintf(line, sizeof(line),
                    "\n%d sources, GPU fusion per reference (mean of %lu): %.2f ms maps onto the device, %.2f check, "
                    "%.2f download into KeyframePoints, %.2f getting them ready; confidence on the GPU (counts, "
                    "confidence, published depth) %.2f ms in all\n\n",
                    sources, static_cast<unsigned long>(fuser.references), fuser.place_ms / n, fuser.check_ms / n,
                    fuser.download_ms / n, fuser.convert_ms / n, fuser.agreement_ms);
      splits += line;
      std::fprintf(stderr, "%s", line);
    }
    std::fprintf(stderr, "pipeline %d sources: %lu depth maps, %lu fused, %lu dropped\n", sources,
                 static_cast<unsigned long>(stats.depth_maps), static_cast<unsigned long>(stats.keyframes_fused),
                 static_cast<unsigned long>(stats.droppedTotal()));
  }
  out << splits;
  return out.str();
}

// Per-keyframe cost against the store's size: `count` keyframes of a room
// loop (100 poses, shifted 1 mm per lap, as the replay) through one pipeline
// whose store keeps them all, without depth ranges (the scene depth and the
// depth range come from the stored depth maps, as in pose input). Per
// keyframe: the step that processes it, then one idle step (late depth maps,
// refinements, fusions again), each timed; medians over the keyframes
// processed while the store held size +- 10 %.
std::string storeTable(int count, int width, int height, Multiscale multiscale) {
  std::ostringstream out;
  out << "\n## Per-keyframe cost against the store's size: " << count << " keyframes of " << width << "x" << height
      << ", 4 sources, every keyframe kept\n\n"
      << "Medians over the keyframes processed while the store held the given number (+- 10 %): the keyframe's step, "
         "its stages, the idle step after it (late depth maps, refinements, fusions again), and keyframes/s as "
         "1000 / (keyframe step + idle step).\n\n"
      << "| stored keyframes | keyframes/s | keyframe step ms | selection | depth range | estimate | fusion | "
         "confidence | map | idle step ms |\n|---|---|---|---|---|---|---|---|---|---|\n";
  const int lap = 100;
  std::vector<Keyframe> loop = roomKeyframes(lap, width, height, 3);
  PipelineOptions options = pipelineOptions(4, multiscale);
  options.mapper.store.max_keyframes = count;
  options.mapper.store.max_bytes = std::numeric_limits<size_t>::max();
  MappingPipeline pipeline(options);
  struct Sample {
    size_t stored;
    double step, selection, range, estimate, fusion, confidence, map, idle;
  };
  std::vector<Sample> samples;
  for (int i = 0; i < count; ++i) {
    Keyframe keyframe = loop[i % lap];
    keyframe.id = i;
    keyframe.stamp = 0.1 * i;
    keyframe.depth_min = keyframe.depth_max = 0;
    Eigen::Isometry3d pose = keyframe.cameraToWorld();
    pose.translation().x() += 0.001 * (i / lap);
    keyframe.setCameraToWorld(pose);
    pipeline.push(std::move(keyframe));
    Sample sample{};
    const auto step_start = std::chrono::steady_clock::now();
    const std::vector<PipelineOutput> outputs = pipeline.step();
    sample.step = millisecondsSince(step_start);
    const auto idle_start = std::chrono::steady_clock::now();
    pipeline.step();
    sample.idle = millisecondsSince(idle_start);
    for (const PipelineOutput& output : outputs) {
      const StageTimes& times = output.result.times;
      if (output.result.id == i) {
        sample.selection = times.selection_ms;
        sample.range = times.depth_range_ms;
        sample.estimate = times.estimate_ms;
      }
      sample.fusion += times.fusion_ms;
      sample.confidence += times.confidence_ms;
      sample.map += times.map_ms;
    }
    sample.stored = pipeline.stats().stored_keyframes;
    samples.push_back(sample);
  }
  for (int size : {50, 200, 500, 1000}) {
    if (size > count) break;
    std::vector<double> step, selection, range, estimate, fusion, confidence, map, idle;
    for (const Sample& sample : samples) {
      if (std::abs(static_cast<double>(sample.stored) - size) > 0.1 * size) continue;
      step.push_back(sample.step);
      selection.push_back(sample.selection);
      range.push_back(sample.range);
      estimate.push_back(sample.estimate);
      fusion.push_back(sample.fusion);
      confidence.push_back(sample.confidence);
      map.push_back(sample.map);
      idle.push_back(sample.idle);
    }
    if (step.empty()) continue;
    char line[300];
    std::snprintf(line, sizeof(line), "| %d | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", size,
                  1000 / (median(step) + median(idle)), median(step), median(selection), median(range),
                  median(estimate), median(fusion), median(confidence), median(map), median(idle));
    out << line;
    std::fprintf(stderr, "%s", line);
  }
  const PipelineStats stats = pipeline.stats();
  out << "\n" << stats.depth_maps << " depth maps (" << stats.refined_depth_maps << " refined), "
      << stats.droppedTotal() << " dropped, backend " << stats.backend << "\n";
  return out.str();
}

// Memory over a long replay: `count` keyframes of 160x120 through one
// pipeline (a rendered loop of 100 poses, shifted 1 mm per lap so that no
// two keyframes share a centre).
std::string replayTable(int count, bool map_in_background, Multiscale multiscale) {
  std::ostringstream out;
  out << "\n## Memory over a long replay: " << count << " keyframes of 160x120, 4 sources";
  if (multiscale.levels > 1) out << ", " << multiscale.levels << " scales";
  out << "\n\n"
      << "| keyframes | host RSS MiB | device used MiB (cudaMemGetInfo) | estimator's device MiB (pool + work) | "
         "stored keyframes | map voxels | ms per keyframe (last interval) |\n|---|---|---|---|---|---|---|\n";
  const int lap = 100;
  const std::vector<Keyframe> loop = roomKeyframes(lap, 160, 120, 2);
  PipelineOptions options = pipelineOptions(4, multiscale);
  options.mapper.map_in_background = map_in_background;
  options.mapper.store.max_keyframes = 50;
  MappingPipeline pipeline(options);
  const int interval = std::max(1, count / 10);
  auto interval_start = std::chrono::steady_clock::now();
  double peak_device = 0, peak_rss = 0;
  for (int i = 0; i < count; ++i) {
    Keyframe keyframe = loop[i % lap];
    keyframe.id = i;
    keyframe.stamp = 0.1 * i;
    Eigen::Isometry3d pose = keyframe.cameraToWorld();
    pose.translation().x() += 0.001 * (i / lap);
    keyframe.setCameraToWorld(pose);
    pipeline.push(std::move(keyframe));
    pipeline.step();  // the new keyframe (see pipelineTable)
    peak_device = std::max(peak_device, deviceUsedMib());
    if ((i + 1) % interval == 0 || i == 0) {
      const PipelineStats stats = pipeline.stats();
      peak_rss = std::max(peak_rss, hostRssMib());
      char line[300];
      std::snprintf(line, sizeof(line), "| %d | %.1f | %.1f | %.1f | %lu | %lu | %.2f |\n", i + 1, hostRssMib(),
                    deviceUsedMib(), stats.gpu_memory_bytes / 1048576.0,
                    static_cast<unsigned long>(stats.stored_keyframes), static_cast<unsigned long>(stats.map_voxels),
                    millisecondsSince(interval_start) / (i == 0 ? 1 : interval));
      out << line;
    std::fprintf(stderr, "%s", line);  // progress: visible if the run is cut short
      interval_start = std::chrono::steady_clock::now();
    }
  }
  const PipelineStats stats = pipeline.stats();
  char line[300];
  std::snprintf(line, sizeof(line),
                "\nPeak device memory in use (sampled after every keyframe): %.1f MiB; peak host RSS: %.1f MiB; "
                "%lu depth maps, %lu dropped; device images: %s\n",
                peak_device, peak_rss, static_cast<unsigned long>(stats.depth_maps),
                static_cast<unsigned long>(stats.droppedTotal()), cacheSummary(pipeline.deviceCacheStats()).c_str());
  out << line;
  return out.str();
}

int hardwareThreads() {
#ifdef _OPENMP
  return omp_get_num_procs();
#else
  return 1;
#endif
}

// "model name" of /proc/cpuinfo and the core count, for the CPU rows.
std::string cpuDescription() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  }
  return model + ", " + std::to_string(hardwareThreads()) + " hardware threads";
}

std::string renderTables(const std::string& device, const std::vector<Row>& rows, const std::string& online) {
  std::ostringstream table;
  table << "device: " << device << "\n\nCPU: " << cpuDescription() << "\n\n"
        << "| scene | size | sources | iterations | backend | median ms | min ms | "
           "with upload ms | ns / (pixel x source x iteration) | GPU MiB |\n"
        << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    const double work = static_cast<double>(r.width) * r.height * r.sources * r.iterations;
    char line[320];
    std::snprintf(line, sizeof(line), "| %s | %dx%d | %d | %d | %s%s | %.1f | %.1f | %.1f | %.3f | %.0f |\n",
                  r.scene.c_str(), r.width, r.height, r.sources, r.iterations, backendName(r.backend),
                  r.threads ? (" (" + std::to_string(r.threads) + " threads)").c_str() : "",
                  r.median_ms, r.min_ms, r.median_total_ms, 1e6 * r.median_ms / work, r.gpu_mib);
    table << line;
  }
  table << online;
  return table.str();
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  using namespace amhmvs;
  std::string data, out_path = "benchmark.md";
  int runs = 5, cpu_threads = 2;
  bool map_foreground = false;  // replay: the voxel-map update in the caller's thread
  bool quick = false;
  int replay_count = 10000;
  Multiscale pipeline_multiscale;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      // The usage is the comment at the top of this file.
      std::printf(
          "usage: amhmvs_benchmark [DATA_DIR] [--out FILE] [--runs N] [--cpu-threads N] [--quick]\n"
          "                        [--only SECTION[,SECTION...]] [--replay N] [--map-foreground]\n"
          "                        [--pipeline-multiscale N[,K]]\n"
          "sections: fountain_x0.25 fountain_x0.5 fountain_x1 synthetic scaling cpu multiscale cpu-scaling\n"
          "          fusion map pipeline store replay pose\n"
          "Writes the tables to FILE (default benchmark.md) after each section and prints them at the end.\n");
      return 0;
    }
    if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
      continue;
    }
    if (a == "--out" && i + 1 < argc) out_path = argv[++i];
    else if (a == "--runs" && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--cpu-threads" && i + 1 < argc) cpu_threads = std::max(1, std::atoi(argv[++i]));
    else if (a == "--quick") quick = true;
    else if (a == "--replay" && i + 1 < argc) replay_count = std::max(1, std::atoi(argv[++i]));
    else if (a == "--map-foreground") map_foreground = true;
    else if (a == "--pipeline-multiscale" && i + 1 < argc) {
      const std::string value = argv[++i];
      pipeline_multiscale.levels = std::max(1, std::atoi(value.c_str()));
      const size_t comma = value.find(',');
      if (comma != std::string::npos) pipeline_multiscale.iterations = std::max(1, std::atoi(value.c_str() + comma + 1));
    }
    else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "amhmvs_benchmark: unknown option or missing value: '%s' (--help lists them)\n", a.c_str());
      return 2;
    } else {
      data = a;
    }
  }
  // --only A,B,...: the named sections only.
  const auto wants = [&only](const std::string& section) {
    return only.empty() || ("," + only + ",").find("," + section + ",") != std::string::npos;
  };
  std::string device;
  const bool gpu = cudaBackendAvailable(&device);
  std::vector<Row> rows;
  std::string online;  // the online pipeline's tables
  try {
    if (gpu) {
      for (const char* name : {"fountain_x0.25", "fountain_x0.5", "fountain_x1"}) {
        const std::string folder = data + "/mvsnet/" + name;
        if (data.empty() || !exists(folder) || !wants(name)) continue;
        const Scene scene = readInputFolder(folder, 10);
        const OwnedDepthProblem owned = makeDepthProblem(scene, 5, ProblemOptions());
        for (int iterations : {6, 3}) rows.push_back(measure(name, owned.problem, Backend::kCuda, iterations, runs, 0));
        std::fprintf(stderr, "%s done\n", name);
      }
      if (wants("synthetic")) {
        const SyntheticProblem vga = makeSyntheticProblem(640, 480, 4);
        for (int iterations : {6, 3}) {
          rows.push_back(measure("synthetic", vga.problem, Backend::kCuda, iterations, runs, 0));
        }
      }
    }
    if (gpu && wants("scaling")) {
      // Time should grow with pixels x sources (the cost matrix dominates).
      const int sizes[][2] = {{320, 240}, {640, 480}, {1280, 960}, {2560, 1920}};
      for (const auto& size : sizes) {
        for (int sources : {2, 4, 8}) {
          const SyntheticProblem p = makeSyntheticProblem(size[0], size[1], sources);
          rows.push_back(measure("scaling", p.problem, Backend::kCuda, 6, runs, 0));
        }
      }
      std::fprintf(stderr, "scaling done\n");
    }
    if (wants("cpu")) {
      for (const auto& size : {std::make_pair(320, 240), std::make_pair(640, 480)}) {
        const SyntheticProblem p = makeSyntheticProblem(size.first, size.second, 4);
        rows.push_back(measure("synthetic", p.problem, Backend::kCpu, 6, quick ? 1 : runs, cpu_threads));
      }
    }
    if (wants("multiscale")) {
      // The coarse-to-fine driver as the product runs it (MappingParameters:
      // 2 scales, the finer one multiscale_iterations from the coarser one's planes).
      PatchMatchOptions two_scales;
      two_scales.multiscale_levels = MappingParameters().pipeline.estimator.multiscale_levels;
      two_scales.multiscale_iterations = MappingParameters().pipeline.estimator.multiscale_iterations;
      if (gpu) {
        const SyntheticProblem vga = makeSyntheticProblem(640, 480, 4);
        rows.push_back(measure("synthetic, 2 scales", vga.problem, Backend::kCuda, 6, runs, 0, two_scales));
      }
      const SyntheticProblem qvga = makeSyntheticProblem(320, 240, 4);
      rows.push_back(
          measure("synthetic, 2 scales", qvga.problem, Backend::kCpu, 6, quick ? 1 : runs, cpu_threads, two_scales));
    }
    if (wants("cpu-scaling")) {
      // The CPU backend at 1, 2, 4, 8 threads, as far as the machine has cores.
      const SyntheticProblem qvga = makeSyntheticProblem(320, 240, 4);
      for (int threads : {1, 2, 4, 8}) {
        if (threads > hardwareThreads()) break;
        rows.push_back(measure("cpu-scaling", qvga.problem, Backend::kCpu, 6, quick ? 1 : runs, threads));
      }
    }
#ifdef _OPENMP
    omp_set_num_threads(omp_get_num_procs());  // the online tables use every core
#endif
    // Written after each section: a run cut short keeps what it measured.
    const auto save = [&] {
      writeFileAtomically(out_path, renderTables(gpu ? device : "none (CPU only)", rows, online), "benchmark tables");
    };
    save();
    if (wants("fusion")) online += fusionTable(std::max(runs, 5));
    save();
    if (wants("map")) online += mapTable(quick ? 12 : 60);
    save();
    if (wants("pipeline")) {
      online += pipelineTable(quick ? 12 : 60, pipeline_multiscale);
      save();
      std::fprintf(stderr, "pipeline done\n");
    }
    if (wants("pose")) {
      online += poseRefinementTable(std::max(runs, 5));
      online += mapCorrectionTable(std::max(runs, 5));
      save();
    }
    if (only.empty() ? !quick : wants("store")) {
      // Small images: the host-side stages are what grows with the store.
      online += gpu ? storeTable(quick ? 240 : 1100, 160, 120, pipeline_multiscale)
                    : storeTable(quick ? 240 : 1100, 80, 60, pipeline_multiscale);
      save();
    }
    if (only.empty() ? !quick : wants("replay")) {
      online += replayTable(replay_count, !map_foreground, pipeline_multiscale);
      save();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "amhmvs_benchmark: %s\n", e.what());
    return 1;
  }
  std::printf("%s", renderTables(gpu ? device : "none (CPU only)", rows, online).c_str());
  return 0;
}
