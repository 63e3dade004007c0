// GPU tests of the estimator, run on the GPU machine by scripts/gpu_machine/gpu_check.sh:
//  - the CPU sampler reproduces the texture unit's bilinear filtering;
//  - each backend is deterministic (bit-identical depth maps run after run);
//  - CPU and GPU agree on real scenes (fraction of pixels within 0.1 % depth);
//  - accuracy on the real data with the paper's defaults, against the public
//    implementation's numbers (floors), on both backends; two scales with the
//    geometric pass against issue 12's Middlebury target;
//  - the online mapping pipeline that the nodelet runs (MappingPipeline:
//    CUDA with its CPU fallback, late depth maps, refinement, deferred
//    fusion) on the fountain views in order, fed like a SLAM
//    adapter's keyframes (image, pose, the sparse points each view observes),
//    at the estimator's settings: its depth maps against the same floors;
//  - the resident image pool of the CUDA backend: same bytes with and without
//    keys, budget, evictions, forget();
//  - fusion on the GPU (DepthMapFuser) against the CPU's fuseDepthMaps on
//    noisy room depth maps: one reference, and every view a reference with
//    "each pixel once" marks; resident maps, budget and evictions; the
//    confidence's agreement counts against the CPU's;
//  - a small scene for compute-sanitizer (--sanitize).
//
// usage: amhmvs_gpu_tests DATA_DIR [--sanitize] [--skip-cpu-fountain]
// DATA_DIR is the output of scripts/gpu_machine/prepare_gpu_data.py.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/eval/depth_metrics.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/simulation/synthetic_scene.h"
#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/depth_filter.h"
#include "amhmvs_mapping/mapping/depth_map_fuser.h"
#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "amhmvs_mapping/mvs/coarse_to_fine.h"
#include "amhmvs_mapping/mvs/cpu_sampler.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "depth_job.h"
#include "gpu/texture_probe.h"

namespace amhmvs {
namespace {

int failures = 0;

void expect(bool ok, const std::string& what) {
  std::printf("%s  %s\n", ok ? "PASS" : "FAIL", what.c_str());
  if (!ok) ++failures;
}

void textureEmulation() {
  std::mt19937 rng(7);
  ImageU8 image(61, 47);
  for (uint8_t& v : image.data) v = static_cast<uint8_t>(rng() & 255);
  std::uniform_real_distribution<float> ux(-3.0f, 64.0f), uy(-3.0f, 50.0f);
  std::vector<float> xs(20000), ys(20000);
  for (size_t i = 0; i < xs.size(); ++i) {
    xs[i] = ux(rng);
    ys[i] = uy(rng);
  }
  const std::vector<float> gpu = sampleTextureOnGpu(image, xs, ys);
  if (const char* dump = std::getenv("AMHMVS_PROBE_DUMP")) {
    // For offline analysis of the texture unit's arithmetic.
    std::FILE* f = std::fopen(dump, "wb");
    if (f) {
      std::fwrite(image.data.data(), 1, image.data.size(), f);
      std::fwrite(xs.data(), sizeof(float), xs.size(), f);
      std::fwrite(ys.data(), sizeof(float), ys.size(), f);
      std::fwrite(gpu.data(), sizeof(float), gpu.size(), f);
      std::fclose(f);
    }
  }
  const mvs::PaddedImage8 host(image);
  double max_diff = 0, sum_diff = 0;
  long off = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    const double d = std::abs(mvs::textureBilinear(host, xs[i], ys[i]) - gpu[i]);
    max_diff = std::max(max_diff, d);
    sum_diff += d;
    off += d > 0.05;
  }
  // The model is exact but for samples whose four weights all fall on ties
  // (about 1 %), where the hardware's rounding is not reproduced.
  char text[200];
  std::snprintf(text, sizeof(text),
                "CPU sampler matches texture fetches: mean |diff| %.5f, max %.3f grey levels, "
                "%.2f %% of samples off by > 0.05",
                sum_diff / xs.size(), max_diff, 100.0 * off / xs.size());
  expect(sum_diff / xs.size() < 0.01 && off < 0.02 * xs.size(), text);
}

DepthMap run(const DepthProblem& problem, Backend backend, const PatchMatchOptions& options = {}) {
  return DepthEstimator(options, backend).estimate(problem);
}

double agreement(const ImageF& a, const ImageF& b, double tolerance) {
  long total = 0, agree = 0;
  for (size_t i = 0; i < a.data.size(); ++i) {
    const float x = a.data[i], y = b.data[i];
    if (!std::isfinite(x) && !std::isfinite(y)) continue;
    ++total;
    agree += std::isfinite(x) && std::isfinite(y) && std::abs(x - y) <= tolerance * y;
  }
  return total ? static_cast<double>(agree) / total : 1.0;
}

bool identical(const ImageF& a, const ImageF& b) {
  return a.data.size() == b.data.size() &&
         std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0;
}

OwnedDepthProblem loadProblem(const std::string& folder, int view, int max_sources = 10,
                              int max_image_size = 0) {
  const Scene scene = readInputFolder(folder, max_sources);
  ProblemOptions options;
  options.max_sources = max_sources;
  options.max_image_size = max_image_size;
  return makeDepthProblem(scene, view, options);
}

void checkFloors(const std::string& label, const AccuracyCounts& counts, const double floors[3]) {
  char text[200];
  std::snprintf(text, sizeof(text), "%s: %s %% (floor %.1f / %.1f / %.1f), %ld samples",
                label.c_str(), counts.percentages().c_str(), floors[0], floors[1], floors[2],
                counts.total);
  bool ok = true;
  for (int i = 0; i < 3; ++i) ok &= 100.0 * counts.fraction(i) >= floors[i];
  expect(ok, text);
}

const char* kMiddleburyScenes[] = {"Adirondack", "Motorcycle", "Piano", "Playtable"};
const double kMiddleburyFloors[3] = {75.4, 82.8, 87.7};
const double kFountainFloors[3] = {98.3, 99.2, 99.5};
// 2 scales with 1 iteration at the finer one through the pipeline
// (onlineMapperFountain), measured on the H100 in session 11: 98.21 / 99.21 /
// 99.47 % (the paper's single scale there: 98.38 / 99.25 / 99.54 %).
const double kFountainTwoScaleFloors[3] = {98.0, 99.1, 99.4};

void middlebury(const std::string& data, Backend backend, bool check_agreement) {
  AccuracyCounts pooled;
  for (const char* scene : kMiddleburyScenes) {
    const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/middlebury2014_" + scene, 0, 1);
    const DepthProblem& problem = owned.problem;
    const DepthMap map = run(problem, backend);
    const MiddleburyGroundTruth gt = readMiddleburyGroundTruth(data + "/middlebury2014/" + scene);
    const AccuracyCounts counts = denseDepthAccuracy(map.depth, gt.depth, &gt.nonoccluded);
    pooled.merge(counts);
    std::printf("  middlebury %-10s %-4s %s %%  (%.0f ms)\n", scene, backendName(backend),
                counts.percentages().c_str(), map.milliseconds);
    if (check_agreement) {
      const DepthMap cpu = run(problem, Backend::kCpu);
      char text[160];
      const double a = agreement(map.depth, cpu.depth, 0.001);
      std::snprintf(text, sizeof(text), "CPU/GPU agreement on middlebury %s: %.2f %% of pixels within 0.1 %% depth",
                    scene, 100 * a);
      std::printf("%s  %s\n", a >= 0.99 ? "PASS" : "INFO", text);
      const MiddleburyGroundTruth& g = gt;
      std::printf("  middlebury %-10s cpu  %s %%  (%.0f ms)\n", scene,
                  denseDepthAccuracy(cpu.depth, g.depth, &g.nonoccluded).percentages().c_str(),
                  cpu.milliseconds);
    }
  }
  checkFloors(std::string("middlebury pooled, ") + backendName(backend), pooled, kMiddleburyFloors);
}

// The geometric pass (amhmvs_depth --geometric): both views of each two-view
// scene photometrically, then view 0 again with view 1's map; pooled against
// the ground truth on the GPU. Agreement: the same inputs (the GPU's
// photometric maps) through the geometric pass on both backends.
void middleburyGeometric(const std::string& data) {
  AccuracyCounts photometric, geometric;
  PatchMatchOptions second;
  second.num_iterations = 3;
  second.first_iteration = second.bisection_only_iterations;
  for (const char* scene : kMiddleburyScenes) {
    const std::string folder = data + "/mvsnet/middlebury2014_" + scene;
    const MiddleburyGroundTruth gt = readMiddleburyGroundTruth(data + "/middlebury2014/" + scene);
    const Scene input = readInputFolder(folder, 1);
    ProblemOptions problem_options;
    problem_options.max_sources = 1;
    SceneImageCache images(input, problem_options);
    std::map<int, DepthMap> maps;
    for (int id : {0, 1}) maps[id] = run(images.makeProblem(id), Backend::kCuda);
    DepthProblem problem = images.makeProblem(0);
    attachGeometricInputs(maps, 0, &problem);
    const DepthMap gpu = DepthEstimator(second, Backend::kCuda).estimate(problem);
    const DepthMap cpu = DepthEstimator(second, Backend::kCpu).estimate(problem);
    photometric.merge(denseDepthAccuracy(maps[0].depth, gt.depth, &gt.nonoccluded));
    geometric.merge(denseDepthAccuracy(gpu.depth, gt.depth, &gt.nonoccluded));
    char text[160];
    const double a = agreement(gpu.depth, cpu.depth, 0.001);
    std::snprintf(text, sizeof(text),
                  "geometric pass, CPU/GPU agreement on middlebury %s (same inputs): %.2f %% of pixels within 0.1 %% depth",
                  scene, 100 * a);
    expect(a >= 0.98, text);
  }
  char text[240];
  std::snprintf(text, sizeof(text),
                "middlebury pooled, cuda: photometric %s %%, geometric pass %s %% (issue 12 target 79.2 / 86.3 / 91.2; "
                "ACMH after its geometric pass 78.2 / 85.3 / 90.2)",
                photometric.percentages().c_str(), geometric.percentages().c_str());
  bool better = true;
  for (int i = 0; i < 3; ++i) better &= geometric.fraction(i) > photometric.fraction(i) + 0.005;
  expect(better, text);
}

// Two scales (--multiscale 2), then the geometric pass, on the GPU: issue
// 12's Middlebury target (the CPU measured 79.73 / 86.59 / 91.32); the CPU/GPU
// agreement of the two-scale photometric maps is reported.
void middleburyMultiscale(const std::string& data) {
  const double target[3] = {79.2, 86.3, 91.2};
  AccuracyCounts pooled;
  for (const char* scene : kMiddleburyScenes) {
    DepthJobOptions options;
    options.backend = Backend::kCuda;
    options.quiet = true;
    options.problem.max_sources = 1;
    options.patchmatch.multiscale_levels = 2;
    options.geometric_iterations = 3;
    const MiddleburyGroundTruth gt = readMiddleburyGroundTruth(data + "/middlebury2014/" + scene);
    runDepthJob(data + "/mvsnet/middlebury2014_" + scene, "", options,
                [&](int id, const DepthProblem&, const DepthMap& map) {
                  if (id == 0) pooled.merge(denseDepthAccuracy(map.depth, gt.depth, &gt.nonoccluded));
                });
  }
  checkFloors("middlebury pooled, cuda, 2 scales + geometric pass (issue 12 target)", pooled, target);
  PatchMatchOptions two_scales;
  two_scales.multiscale_levels = 2;
  const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/middlebury2014_Piano", 0, 1);
  const DepthMap gpu = run(owned.problem, Backend::kCuda, two_scales);
  const DepthMap cpu = run(owned.problem, Backend::kCpu, two_scales);
  std::printf("INFO  2 scales, CPU/GPU agreement on middlebury Piano: %.2f %% of pixels within 0.1 %% depth "
              "(%.1f ms on the GPU)\n",
              100 * agreement(gpu.depth, cpu.depth, 0.001), gpu.milliseconds);
}

// The planar prior (mvs/planar_prior.h) on the GPU: the same pooled
// Middlebury accuracy as the CPU (two scales, one finer iteration; the CPU
// measured 78.69 -> 79.48 / 86.39 -> 86.69 % within 1 / 2 % with the prior),
// better than none at 1 %, and the first pass leaves the last result alone.
void middleburyPlanarPrior(const std::string& data) {
  PatchMatchOptions options;
  options.multiscale_levels = 2;
  options.multiscale_iterations = 1;
  PatchMatchOptions with_prior = options;
  with_prior.planar_prior = true;
  AccuracyCounts gpu_none, gpu_prior, cpu_prior;
  for (const char* scene : kMiddleburyScenes) {
    const MiddleburyGroundTruth gt = readMiddleburyGroundTruth(data + "/middlebury2014/" + scene);
    const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/middlebury2014_" + scene, 0, 1);
    gpu_none.merge(denseDepthAccuracy(run(owned.problem, Backend::kCuda, options).depth, gt.depth, &gt.nonoccluded));
    gpu_prior.merge(
        denseDepthAccuracy(run(owned.problem, Backend::kCuda, with_prior).depth, gt.depth, &gt.nonoccluded));
    cpu_prior.merge(
        denseDepthAccuracy(run(owned.problem, Backend::kCpu, with_prior).depth, gt.depth, &gt.nonoccluded));
  }
  char text[240];
  std::snprintf(text, sizeof(text), "middlebury pooled, planar prior: cuda %s %% (without %s %%), cpu %s %%",
                gpu_prior.percentages().c_str(), gpu_none.percentages().c_str(), cpu_prior.percentages().c_str());
  bool agree = true;
  for (int i = 0; i < 3; ++i) agree &= std::abs(gpu_prior.fraction(i) - cpu_prior.fraction(i)) < 0.003;
  expect(agree && gpu_prior.fraction(0) > gpu_none.fraction(0), text);
  // The last result stays valid on the device through a two-pass estimate.
  const OwnedDepthProblem piano = loadProblem(data + "/mvsnet/middlebury2014_Piano", 0, 1);
  DepthEstimator estimator(with_prior, Backend::kCuda);
  const DepthMap first = estimator.estimate(piano.problem);
  const DeviceDepthMap outputs = estimator.lastDeviceOutputs();
  expect(outputs.host_depth == first.depth.data.data(), "planar prior: the device outputs are the second pass's");
}

// A dense folder's view as a keyframe: its id as id and stamp.
Keyframe sceneKeyframe(const SceneView& view) {
  Keyframe keyframe;
  keyframe.id = view.id;
  keyframe.stamp = view.id;
  keyframe.image = readImage(view.image_path);
  keyframe.camera = view.camera;
  return keyframe;
}

// The next scale of a coarse-to-fine estimate starts from the coarser
// scale's planes, carried on the device from the estimator's own outputs
// (no host round trip): the same map, bit for bit, as when the coarser maps
// come from the host (a copy the estimator did not make: uploaded first).
void coarseToFineCarriedOnDevice(const std::string& data) {
  const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/middlebury2014_Piano", 0, 1);
  PatchMatchOptions two_scales;
  two_scales.multiscale_levels = 2;
  const DepthMap on_device = run(owned.problem, Backend::kCuda, two_scales);
  int scales = 0;
  const DepthMap uploaded =
      mvs::estimateCoarseToFine(two_scales, owned.problem, [&](const PatchMatchOptions& options, const DepthProblem& problem) {
        ++scales;
        DepthMap map = run(problem, Backend::kCuda, options);  // a fresh estimator per scale
        DepthMap copy = map;  // other host memory: the next scale uploads it
        return copy;
      });
  expect(scales == 2 && identical(on_device.depth, uploaded.depth) && identical(on_device.normal, uploaded.normal) &&
             identical(on_device.cost, uploaded.cost),
         "2 scales: the finer scale's start carried on the device equals the one uploaded from the host");
}

// Two scales through the pipeline, every keyframe queued at once, so that a
// keyframe is fused while the next one is estimated: the coarser scale's
// outputs must not overwrite the last result being fused. The same map with
// the overlap as without it.
void pipelineTwoScalesWithFusionOverlap(const std::string& data) {
  const std::string folder = data + "/mvsnet/fountain_x0.25";
  const Scene scene = readInputFolder(folder, 10);
  struct Outcome {
    uint64_t fused = 0, points = 0, voxels = 0;
    double estimate_ms = 0, own_ms = 0;
    int estimates = 0;
  };
  const auto map_with = [&](FusionOverlap overlap) {
    PipelineOptions options;
    options.backend = Backend::kCuda;
    options.estimator.multiscale_levels = 2;
    options.mapper.map.leaf_size = 0.02;
    options.queue_size = scene.views.size();
    options.fusion_overlap = overlap;
    MappingPipeline pipeline(options);
    for (const SceneView& view : scene.views) pipeline.push(sceneKeyframe(view));
    Outcome outcome;
    pipeline.runUntilIdle([&](const PipelineOutput& output) {
      if (!output.result.has_depth) return;
      ++outcome.estimates;
      outcome.estimate_ms += output.result.times.estimate_ms;
      outcome.own_ms += output.result.depth->milliseconds;
    });
    const PipelineStats stats = pipeline.stats();
    outcome.fused = stats.keyframes_fused;
    outcome.points = stats.map_points_added;
    outcome.voxels = stats.map_voxels;
    return outcome;
  };
  const Outcome overlapped = map_with(FusionOverlap::kGpu), serial = map_with(FusionOverlap::kOff);
  char text[300];
  std::snprintf(text, sizeof(text),
                "pipeline, 2 scales, fountain x0.25: %lu keyframes fused, %lu points, %lu voxels with a keyframe fused "
                "during the next estimate; %lu, %lu, %lu without (estimate %.1f ms a depth map, the estimator's own "
                "%.1f ms)",
                static_cast<unsigned long>(overlapped.fused), static_cast<unsigned long>(overlapped.points),
                static_cast<unsigned long>(overlapped.voxels), static_cast<unsigned long>(serial.fused),
                static_cast<unsigned long>(serial.points), static_cast<unsigned long>(serial.voxels),
                overlapped.estimate_ms / std::max(1, overlapped.estimates), overlapped.own_ms / std::max(1, overlapped.estimates));
  expect(overlapped.fused > 0 && overlapped.points > 0 && overlapped.fused == serial.fused &&
             overlapped.points == serial.points && overlapped.voxels == serial.voxels,
         text);
}

// Kernel time per map of the geometric pass (3 iterations from the
// photometric maps), median over the views of a fountain size.
void geometricSpeed(const std::string& data, const std::string& name) {
  const std::string folder = data + "/mvsnet/" + name;
  DepthJobOptions options;
  options.backend = Backend::kCuda;
  options.quiet = true;
  options.geometric_iterations = 3;
  std::vector<double> ms;
  runDepthJob(folder, "", options,
              [&](int, const DepthProblem&, const DepthMap& map) { ms.push_back(map.compute_milliseconds); });
  std::sort(ms.begin(), ms.end());
  std::printf("INFO  geometric pass, %s: %.1f ms per map (median of %zu; kernels and download)\n", name.c_str(),
              ms.empty() ? 0.0 : ms[ms.size() / 2], ms.size());
}

void fountain(const std::string& data, Backend backend) {
  const std::string folder = data + "/mvsnet/fountain_x0.25";
  const std::vector<SparsePoint> points = readSparsePoints(folder + "/sparse_points.txt");
  AccuracyCounts pooled;
  DepthJobOptions options;
  options.backend = backend;
  options.quiet = true;
  double ms = 0;
  runDepthJob(folder, "", options, [&](int id, const DepthProblem& problem, const DepthMap& map) {
    pooled.merge(sparsePointAccuracy(map.depth, problem.reference_camera, id, points));
    ms += map.milliseconds;
  });
  std::printf("  fountain_x0.25 %s: %.0f ms for 11 depth maps\n", backendName(backend), ms);
  checkFloors(std::string("fountain_x0.25 sparse agreement, ") + backendName(backend), pooled,
              kFountainFloors);
}

// The fountain views as keyframes in order through the nodelet's pipeline
// (MappingPipeline: CUDA with its CPU fallback, late depth maps, refinement)
// on the GPU, pushed one at a time as a SLAM front end would, each followed
// by steps until the pipeline is idle (the GPU keeps up, so the queue stays
// empty). `check`: against the estimator's floors (else reported only).
void onlineMapperFountain(const std::string& data, const std::string& label, const OnlineMapperOptions& mapper_options,
                          const PatchMatchOptions& estimator, const double* floors) {
  const std::string folder = data + "/mvsnet/fountain_x0.25";
  const Scene scene = readInputFolder(folder, 10);
  const std::vector<SparsePoint> points = readSparsePoints(folder + "/sparse_points.txt");
  PipelineOptions options;
  options.mapper = mapper_options;
  options.estimator = estimator;
  options.backend = Backend::kCuda;
  MappingPipeline pipeline(options, [](MappingPipeline::LogLevel, const std::string& line) {
    std::printf("INFO  pipeline: %s\n", line.c_str());
  });
  int estimates = 0, on_cpu = 0;
  double ms = 0;
  std::map<int64_t, DepthMap> latest;
  std::map<int64_t, PinholeCamera> cameras;
  const auto keep = [&](const PipelineOutput& output) {
    const KeyframeResult& result = output.result;
    if (!result.has_depth) return;
    ++estimates;
    on_cpu += result.depth->backend != Backend::kCuda;
    ms += result.depth->milliseconds;
    latest[result.id] = result.depth;
    cameras[result.id] = result.camera;
    std::printf("  keyframe %2ld%-8s %zu sources, depth %.1f..%.1f m (%s), %.1f ms estimate, %.1f ms in all: %s %%\n",
                static_cast<long>(result.id), result.late ? " late" : result.refined ? " refined" : "",
                result.selection.source_ids.size(), result.depth_range.min, result.depth_range.max,
                depthRangeSourceName(result.depth_range.source), result.times.estimate_ms, result.times.total_ms,
                sparsePointAccuracy(result.depth->depth, result.camera, static_cast<int>(result.id), points)
                    .percentages().c_str());
  };
  for (const SceneView& view : scene.views) {
    Keyframe keyframe = sceneKeyframe(view);
    for (const SparsePoint& point : points)
      for (int observer : point.views)
        if (observer == view.id) keyframe.sparse_points.push_back(point.position);
    pipeline.push(std::move(keyframe));
    pipeline.runUntilIdle(keep);
  }
  AccuracyCounts pooled;
  for (const auto& entry : latest)
    pooled.merge(sparsePointAccuracy(entry.second.depth, cameras.at(entry.first), static_cast<int>(entry.first), points));
  const PipelineStats stats = pipeline.stats();
  std::printf("  pipeline, %s: %d estimates (%zu keyframes, %lu refined) in %.0f ms of estimation, map %lu voxels, "
              "%lu keyframes fused\n", label.c_str(), estimates, latest.size(),
              static_cast<unsigned long>(stats.refined_depth_maps), ms, static_cast<unsigned long>(stats.map_voxels),
              static_cast<unsigned long>(stats.keyframes_fused));
  expect(latest.size() == scene.views.size() && on_cpu == 0 && stats.cpu_fallbacks == 0 && stats.backend == "cuda",
         "pipeline on the GPU, " + label + ": a depth map for every fountain keyframe, no CPU fallback");
  // Replaced depth maps leave the fuser's device cache when their successor
  // is fused (not when the budget pushes them out): at most one map per
  // keyframe stays resident; a reset empties it.
  const FuserCacheStats cache = pipeline.fusionCacheStats();
  const DepthMap& any_map = latest.begin()->second;
  const size_t map_bytes = any_map.depth.data.size() * (5 * sizeof(float) + 3);  // depth, normal, cost, RGB
  pipeline.requestReset();
  pipeline.runUntilIdle(keep);
  const FuserCacheStats after_reset = pipeline.fusionCacheStats();
  char text[300];
  std::snprintf(text, sizeof(text),
                "pipeline on the GPU, %s: fuser cache %lu uploads, %lu forgotten, %.1f MB resident for %zu keyframes "
                "(<= %.1f MB: one map each); after a reset %zu bytes",
                label.c_str(), static_cast<unsigned long>(cache.uploads), static_cast<unsigned long>(cache.forgotten),
                cache.resident_bytes / 1e6, latest.size(), latest.size() * map_bytes / 1e6,
                after_reset.resident_bytes);
  expect(cache.forgotten > 0 && cache.resident_bytes <= latest.size() * map_bytes && after_reset.resident_bytes == 0,
         text);
  // Each depth map is uploaded to the fuser once (its key is its store
  // revision), and the estimator's device outputs are copied rather than
  // uploaded whenever the map is fused in the step that estimated it.
  std::snprintf(text, sizeof(text),
                "pipeline on the GPU, %s: %lu fuser uploads for %d depth maps (at most one each), %lu of them "
                "copied from the estimator on the device",
                label.c_str(), static_cast<unsigned long>(cache.uploads), estimates,
                static_cast<unsigned long>(cache.device_copies));
  expect(cache.uploads <= static_cast<uint64_t>(estimates) && cache.device_copies > 0, text);
  const std::string what = "pipeline (nodelet core, CUDA), " + label + ": fountain_x0.25 sparse agreement";
  if (floors)
    checkFloors(what, pooled, floors);
  else
    std::printf("INFO  %s: %s %%\n", what.c_str(), pooled.percentages().c_str());
}

void onlineMapperFountain(const std::string& data) {
  OnlineMapperOptions defaults;  // the nodelet's defaults, up to 10 sources
  defaults.sources.max_sources = 10;
  defaults.map.leaf_size = 0.02;
  const PatchMatchOptions paper;  // 6 iterations, one scale
  onlineMapperFountain(data, "default source criteria", defaults, paper, nullptr);
  // The estimator's floor lets every other view of the 110 deg arc be a
  // source (pair.txt); source selection's default angle limits (30 deg
  // triangulation, 45 deg optical axes) keep only 2 for the last keyframe.
  OnlineMapperOptions wide = defaults;
  wide.sources.max_triangulation_angle_deg = 60;
  wide.sources.max_axis_angle_deg = 60;
  onlineMapperFountain(data, "sources within 60 deg", wide, paper, kFountainFloors);
  // The setting for real video (2 scales, 1 iteration at the finer one):
  // a little worse at 1 % on these exact cameras (the CPU, offline: 98.23 /
  // 99.23 / 99.52 %).
  PatchMatchOptions two_scales;
  two_scales.multiscale_levels = 2;
  two_scales.multiscale_iterations = 1;
  onlineMapperFountain(data, "sources within 60 deg, 2 scales", wide, two_scales, kFountainTwoScaleFloors);
}

bool identicalMaps(const DepthMap& a, const DepthMap& b) {
  return identical(a.depth, b.depth) && identical(a.normal, b.normal) && identical(a.cost, b.cost);
}

DepthProblem withoutKeys(DepthProblem problem) {
  problem.reference_key = kNoImageKey;
  problem.source_keys.clear();
  return problem;
}

// Fountain x0.25 views at `max_image_size`, 4 sources each, images read once
// (problems carry the view ids as image keys).
struct FountainImages {
  FountainImages(const std::string& data, int max_image_size)
      : scene(readInputFolder(data + "/mvsnet/fountain_x0.25", 4)), images(scene, options(max_image_size)) {}
  static ProblemOptions options(int max_image_size) {
    ProblemOptions problem;
    problem.max_sources = 4;
    problem.max_image_size = max_image_size;
    return problem;
  }
  Scene scene;
  SceneImageCache images;
};

// The CUDA backend's pool of resident images: every fountain view at 384 px
// as a reference with 4 sources, in order (each image serves ~5 problems).
// Keyed problems must give the bytes of unkeyed ones with any budget; the
// budget bounds what stays resident; evictions, uploads and hits are counted;
// forget() makes the next use upload the (new) pixels.
void residentPool(const std::string& data) {
  FountainImages fountain(data, 384);
  const Scene& scene = fountain.scene;
  SceneImageCache& images = fountain.images;
  PatchMatchOptions options;
  options.num_iterations = 3;  // enough to use every image; halves the time
  EstimatorResources roomy, tight;
  roomy.device_image_budget_bytes = size_t(64) << 20;
  const size_t slot = 384 * 256;
  tight.device_image_budget_bytes = 3 * slot;  // 3 images kept; a problem needs 5
  DepthEstimator unkeyed(options, Backend::kCuda), resident(options, Backend::kCuda, roomy),
      evicting(options, Backend::kCuda, tight);
  bool same_resident = true, same_evicting = true, within_budget = true;
  for (const SceneView& view : scene.views) {
    const DepthProblem problem = images.makeProblem(view.id);
    const DepthMap reference = unkeyed.estimate(withoutKeys(problem));
    same_resident &= identicalMaps(reference, resident.estimate(problem));
    same_evicting &= identicalMaps(reference, evicting.estimate(problem));
    const DeviceCacheStats stats = evicting.deviceCacheStats();
    within_budget &= stats.resident_bytes <= stats.budget_bytes && stats.resident_images <= 3;
  }
  const DeviceCacheStats roomy_stats = resident.deviceCacheStats(), tight_stats = evicting.deviceCacheStats(),
                         unkeyed_stats = unkeyed.deviceCacheStats();
  std::printf("INFO  pool (64 MiB): %lu uploads, %lu hits, %lu evictions, %zu resident, pool %.1f MiB, work %.1f MiB\n",
              static_cast<unsigned long>(roomy_stats.uploads), static_cast<unsigned long>(roomy_stats.hits),
              static_cast<unsigned long>(roomy_stats.evictions), roomy_stats.resident_images,
              roomy_stats.pool_bytes / 1048576.0, roomy_stats.work_bytes / 1048576.0);
  std::printf("INFO  pool (3 images): %lu uploads, %lu hits, %lu evictions, %zu resident, pool %.1f MiB\n",
              static_cast<unsigned long>(tight_stats.uploads), static_cast<unsigned long>(tight_stats.hits),
              static_cast<unsigned long>(tight_stats.evictions), tight_stats.resident_images,
              tight_stats.pool_bytes / 1048576.0);
  const uint64_t views = scene.views.size();
  expect(same_resident && same_evicting,
         "resident images give the same depth, normal and cost bytes as per-estimate uploads (11 fountain views, "
         "budget of 64 MiB and of 3 images)");
  expect(roomy_stats.uploads == views && roomy_stats.evictions == 0 && roomy_stats.hits > 2 * views &&
             roomy_stats.resident_images == views,
         "roomy budget: each image uploaded once, nothing evicted, the rest are hits");
  expect(within_budget && tight_stats.evictions > 0 && tight_stats.uploads > views &&
             tight_stats.uploads == tight_stats.evictions + tight_stats.resident_images,
         "budget of 3 images: never more resident, evictions counted (uploads = evictions + resident)");
  expect(unkeyed_stats.uploads == 0 && unkeyed_stats.resident_images == 0 && unkeyed_stats.unkeyed_uploads == 4 * views,
         "images without keys are uploaded per estimate and not kept (4 sources; the reference goes straight to "
         "the kernels' buffer)");

  // forget(): the key's next use uploads the pixels it has then.
  const DepthProblem problem = images.makeProblem(scene.views[5].id);
  ImageU8 changed(problem.source_images[0].width, problem.source_images[0].height);
  for (size_t i = 0; i < changed.data.size(); ++i) changed.data[i] = static_cast<uint8_t>(255 - problem.source_images[0].data[i]);
  DepthProblem changed_problem = problem;
  changed_problem.source_images[0] = changed;
  const uint64_t uploads_before = resident.deviceCacheStats().uploads;
  resident.forget(problem.source_keys[0]);
  const DeviceCacheStats after_forget = resident.deviceCacheStats();
  const DepthMap after = resident.estimate(changed_problem);
  expect(after_forget.forgotten == 1 && after_forget.resident_images == views - 1 &&
             resident.deviceCacheStats().uploads == uploads_before + 1 &&
             identicalMaps(after, unkeyed.estimate(withoutKeys(changed_problem))) &&
             !identicalMaps(after, unkeyed.estimate(withoutKeys(problem))),
         "forget(key): dropped, counted, and the next estimate uses the new pixels");
  resident.forgetAll();
  expect(resident.deviceCacheStats().resident_images == 0, "forgetAll() leaves nothing resident");

  // A key whose image changed size without forget() is refused.
  const ImageU8 smaller(problem.source_images[1].width - 1, problem.source_images[1].height);
  PinholeCamera smaller_camera = problem.source_cameras[1];
  smaller_camera.width -= 1;
  DepthProblem resized = problem;
  resized.source_images[1] = smaller;
  resized.source_cameras[1] = smaller_camera;
  resident.estimate(problem);  // every key resident at its old size
  bool refused = false;
  try {
    resident.estimate(resized);
  } catch (const InputError& e) {
    refused = std::string(e.what()).find("without forget") != std::string::npos;
  }
  expect(refused, "a key whose image changed size without forget() is refused (InputError)");
  const DepthMap recovered = resident.estimate(problem);
  expect(identicalMaps(recovered, unkeyed.estimate(withoutKeys(problem))), "the estimator works after that refusal");
}

// Coarse-to-fine's coarser copies in their own pool (slots of their size):
// with room, every image and every half-size copy stays resident, nothing
// evicted, a quarter more bytes than one scale; within a budget of 5
// full-size images, 4 of each (the copies' fifth of the budget holds as many
// as the rest). The maps do not depend on the budget.
void coarserCopiesPool(const std::string& data) {
  FountainImages fountain(data, 384);
  PatchMatchOptions one_scale, two_scales;
  one_scale.num_iterations = two_scales.num_iterations = 3;
  two_scales.multiscale_levels = 2;
  const size_t slot = 384 * 256;
  EstimatorResources roomy, tight;
  roomy.device_image_budget_bytes = size_t(64) << 20;
  tight.device_image_budget_bytes = 5 * slot;
  DepthEstimator single(one_scale, Backend::kCuda, roomy), double_roomy(two_scales, Backend::kCuda, roomy),
      double_tight(two_scales, Backend::kCuda, tight);
  bool same = true, within_budget = true;
  for (const SceneView& view : fountain.scene.views) {
    const DepthProblem problem = fountain.images.makeProblem(view.id);
    single.estimate(problem);
    same &= identicalMaps(double_roomy.estimate(problem), double_tight.estimate(problem));
    const DeviceCacheStats stats = double_tight.deviceCacheStats();
    within_budget &= stats.resident_bytes <= stats.budget_bytes;
  }
  const DeviceCacheStats one = single.deviceCacheStats(), two = double_roomy.deviceCacheStats(),
                         tight_two = double_tight.deviceCacheStats();
  const size_t views = fountain.scene.views.size();
  char text[400];
  std::snprintf(text, sizeof(text),
                "coarser copies in their own pool, fountain 384x256, 2 scales: %zu images resident in %zu bytes, %lu "
                "evictions (one scale: %zu in %zu); within 5 images' bytes %zu resident in %zu bytes (budget %zu), "
                "%lu evictions, maps identical: %s",
                two.resident_images, two.resident_bytes, static_cast<unsigned long>(two.evictions),
                one.resident_images, one.resident_bytes, tight_two.resident_images, tight_two.resident_bytes,
                tight_two.budget_bytes, static_cast<unsigned long>(tight_two.evictions), same ? "yes" : "no");
  expect(same && within_budget && one.resident_images == views && two.evictions == 0 &&
             two.resident_images == 2 * views && two.resident_bytes == views * slot + views * slot / 4 &&
             tight_two.resident_images == 8 && tight_two.resident_bytes == 4 * slot + 4 * slot / 4,
         text);
}

void determinism(const std::string& data) {
  const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/fountain_x0.25", 3, 10, 384);
  const DepthProblem& problem = owned.problem;
  for (Backend backend : {Backend::kCuda, Backend::kCpu}) {
    const DepthMap a = run(problem, backend), b = run(problem, backend);
    expect(identical(a.depth, b.depth) && identical(a.normal, b.normal) && identical(a.cost, b.cost),
           std::string("deterministic ") + backendName(backend) + " (fountain view 3 at 384 px, twice)");
  }
  PatchMatchOptions other_seed;
  other_seed.random_seed = 1;
  const DepthMap a = run(problem, Backend::kCuda), c = run(problem, Backend::kCuda, other_seed);
  expect(!identical(a.depth, c.depth), "another seed gives another depth map");
  const DepthMap cpu = run(problem, Backend::kCpu);
  char text[160];
  std::snprintf(text, sizeof(text), "CPU/GPU agreement on fountain view 3: %.2f %% within 0.1 %% depth",
                100 * agreement(a.depth, cpu.depth, 0.001));
  std::printf("INFO  %s\n", text);
}

}  // namespace
}  // namespace amhmvs

namespace amhmvs {
namespace {

// Rendered room views with depth noise (0.3 %) and tilted normals, so that
// many pixels sit near the fusion's thresholds.
struct NoisyRoom {
  std::vector<DepthMapImages> maps;
  std::vector<PinholeCamera> cameras;
  NoisyRoom(int count, int width, int height) {
    const SyntheticWorld world = makeIndoorRoomWorld(3);
    cameras = makeSmoothTrajectory(count, width, height, 3);
    std::mt19937 rng(11);
    std::normal_distribution<float> noise(0.0f, 0.003f);
    for (int i = 0; i < count; ++i) {
      RenderedView view = renderView(world, cameras[i], 1);
      for (float& d : view.depth.data) d *= 1.0f + noise(rng);
      for (float& n : view.normal.data) n += 4 * noise(rng);
      DepthMapImages images;
      images.depth = std::move(view.depth);
      images.normal = std::move(view.normal);
      images.color = std::move(view.image);
      maps.push_back(std::move(images));
    }
  }
  // View i (key = i + key_offset, or none); sources as given.
  FusionView view(int i, std::vector<int> sources, int64_t key) const {
    FusionView v = maps[i].borrow(i, cameras[i]);
    v.source_ids = std::move(sources);
    v.key = key;
    return v;
  }
};

// Fraction of points that differ between two fusions (by count, and by
// position beyond 1e-5 m where the lists line up).
double fusionDifference(const FusionResult& a, const FusionResult& b, double* max_offset) {
  size_t differing = 0, total = 0;
  *max_offset = 0;
  for (size_t v = 0; v < a.views.size(); ++v) {
    const KeyframePoints& pa = a.views[v].points;
    const KeyframePoints& pb = b.views[v].points;
    total += std::max(pa.size(), pb.size());
    if (pa.size() != pb.size()) {
      differing += pa.size() > pb.size() ? pa.size() - pb.size() : pb.size() - pa.size();
      continue;
    }
    for (size_t i = 0; i < pa.size(); ++i) {
      const double offset = (pa[i].position - pb[i].position).norm();
      *max_offset = std::max(*max_offset, offset);
      differing += offset > 1e-5 || pa[i].consistent_views != pb[i].consistent_views;
    }
  }
  return total ? static_cast<double>(differing) / total : 0.0;
}

// The temporal depth filter on both backends (the same filterPixel): from
// the rendered keyframe's depth 3 % off, 8 frames; the GPU's beliefs must
// match the CPU's (texture fetches emulated on the CPU: equal up to float
// rounding), and per update time after warm-up (INFO).
void depthFilterAgreement(int width, int height) {
  const SyntheticWorld world = makeSlantedPlanesWorld(3);
  const std::vector<PinholeCamera> cameras = makeSidewaysCameras(9, width, height, 0.15);
  std::vector<ImageU8> gray;
  DepthMap start;
  for (size_t i = 0; i < cameras.size(); ++i) {
    RenderedView view = renderView(world, cameras[i], 2);
    gray.push_back(toGray(view.image));
    if (i == 0) {
      start.depth = view.depth;
      start.normal = view.normal;
    }
  }
  for (float& depth : start.depth.data) depth *= 1.03f;
  KeyframeDepthFilter cpu(cameras[0], gray[0], start, DepthFilterOptions());
  KeyframeDepthFilter gpu(cameras[0], gray[0], start, DepthFilterOptions(), /*on_gpu=*/true);
  expect(gpu.onGpu(), "depth filter: on the GPU");
  size_t cpu_matched = 0, gpu_matched = 0;
  std::vector<double> update_ms;
  for (size_t i = 1; i < cameras.size(); ++i) {
    cpu_matched += cpu.update(cameras[i], gray[i]).matched;
    const auto begin = std::chrono::steady_clock::now();
    gpu_matched += gpu.update(cameras[i], gray[i]).matched;
    update_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count());
  }
  const ImageF cpu_mean = cpu.mean(), gpu_mean = gpu.mean(), cpu_depth = cpu.depth(), gpu_depth = gpu.depth();
  size_t both = 0, close = 0, published_same = 0;
  for (size_t i = 0; i < cpu_mean.data.size(); ++i) {
    if (!std::isfinite(cpu_mean.data[i])) continue;
    ++both;
    if (std::abs(gpu_mean.data[i] / cpu_mean.data[i] - 1) < 1e-3) ++close;
    if (std::isfinite(cpu_depth.data[i]) == std::isfinite(gpu_depth.data[i])) ++published_same;
  }
  std::sort(update_ms.begin() + 1, update_ms.end());
  char text[300];
  std::snprintf(text, sizeof(text),
                "depth filter %dx%d: GPU mean within 0.1 %% of the CPU's at %.3f %% of %zu pixels, published alike at "
                "%.3f %%, matches %zu / %zu",
                width, height, 100.0 * close / both, both, 100.0 * published_same / both, gpu_matched, cpu_matched);
  expect(both > 0 && close >= 0.995 * both && published_same >= 0.995 * both &&
             std::abs(static_cast<double>(gpu_matched) - cpu_matched) <= 0.005 * cpu_matched,
         text);
  std::printf("INFO  depth filter %dx%d: GPU update (upload, kernel, counts) median %.2f ms after warm-up\n", width,
              height, update_ms[1 + (update_ms.size() - 1) / 2]);
}

void gpuFusion(int width, int height) {
  const NoisyRoom room(6, width, height);
  const FusionOptions options = FusionOptions::reprojection();
  char text[300];
  // The mapper's case: one reference against five views, and every view a
  // reference against all others (marks decide which view keeps a point).
  for (bool all_references : {false, true}) {
    std::vector<FusionView> views;
    for (int i = 0; i < 6; ++i) {
      std::vector<int> sources;
      if (i == 0 || all_references) {
        for (int j = 0; j < 6; ++j) {
          if (j != i) sources.push_back(j);
        }
      }
      views.push_back(room.view(i, sources, i));
    }
    const FusionResult cpu = fuseDepthMaps(views, options);
    DepthMapFuser fuser(Backend::kCuda);
    const FusionResult gpu = fuser.fuse(views, options);
    const FusionResult again = fuser.fuse(views, options);  // resident maps
    double max_offset = 0;
    const double differing = fusionDifference(cpu, gpu, &max_offset);
    double repeat_offset = 0;
    const double repeat = fusionDifference(gpu, again, &repeat_offset);
    const FuserCacheStats stats = fuser.cacheStats();
    std::snprintf(text, sizeof(text),
                  "GPU fusion %dx%d, %s: %zu points (CPU %zu), candidates %zu / %zu, %.4f %% differ "
                  "(<= 0.05 %%), max offset %.2g m; again from resident maps: identical; uploads %lu, hits %lu",
                  width, height, all_references ? "every view a reference" : "one reference", gpu.pointCount(),
                  cpu.pointCount(), gpu.candidate_pixels, cpu.candidate_pixels, 100 * differing, max_offset,
                  static_cast<unsigned long>(stats.uploads), static_cast<unsigned long>(stats.hits));
    expect(cpu.pointCount() > 1000 && differing <= 5e-4 && max_offset < 1e-4 &&
               gpu.candidate_pixels == cpu.candidate_pixels && repeat == 0 && repeat_offset == 0 &&
               stats.uploads == 6 && stats.hits == 6,
           text);
  }
  // A budget of three maps and two alternating groups of three views:
  // evictions, the same result each time.
  const auto group = [&](int first) {
    std::vector<FusionView> views;
    for (int i = first; i < first + 3; ++i) {
      views.push_back(room.view(i, i == first + 2 ? std::vector<int>{first, first + 1} : std::vector<int>{}, 100 + i));
    }
    return views;
  };
  FuserResources small;
  small.device_map_budget_bytes = 3 * static_cast<size_t>(width) * height * (16 + 3);
  DepthMapFuser budgeted(Backend::kCuda, small);
  const FusionResult first = budgeted.fuse(group(0), options);
  budgeted.fuse(group(3), options);
  const FusionResult third = budgeted.fuse(group(0), options);
  double offset = 0;
  const double differing = fusionDifference(first, third, &offset);
  const FuserCacheStats stats = budgeted.cacheStats();
  std::snprintf(text, sizeof(text),
                "GPU fusion within a 3-map budget: %lu evictions, %lu uploads, %zu of %zu bytes resident, "
                "result identical",
                static_cast<unsigned long>(stats.evictions), static_cast<unsigned long>(stats.uploads),
                stats.resident_bytes, small.device_map_budget_bytes);
  expect(stats.evictions == 6 && stats.uploads == 9 && differing == 0 && offset == 0 && first.pointCount() > 0 &&
             stats.resident_bytes <= small.device_map_budget_bytes,
         text);
  // forget() frees one map at once, forgetAll() the rest; the next call
  // uploads again and gives the same points.
  const size_t before = stats.resident_bytes;
  budgeted.forget(100);
  budgeted.forget(12345);  // unknown: nothing
  const FuserCacheStats one_forgotten = budgeted.cacheStats();
  budgeted.forgetAll();
  const FuserCacheStats all_forgotten = budgeted.cacheStats();
  const FusionResult refused = budgeted.fuse(group(0), options);
  const double after_forget = fusionDifference(first, refused, &offset);
  const FuserCacheStats final_stats = budgeted.cacheStats();
  std::snprintf(text, sizeof(text),
                "GPU fusion forget: %zu -> %zu -> %zu bytes resident, %lu forgotten, %lu uploads after, result "
                "identical",
                before, one_forgotten.resident_bytes, all_forgotten.resident_bytes,
                static_cast<unsigned long>(all_forgotten.forgotten), static_cast<unsigned long>(final_stats.uploads));
  expect(one_forgotten.resident_bytes == before / 3 * 2 && one_forgotten.forgotten == 1 &&
             all_forgotten.resident_bytes == 0 && all_forgotten.forgotten == 3 && final_stats.uploads == 12 &&
             after_forget == 0 && offset == 0,
         text);
}

// The confidence's agreement counts on the GPU (DepthMapFuser::countAgreement,
// the kernel over resident maps) against the CPU loop: the same per-pixel
// check, so the counts differ at most where a test lands within rounding of
// its threshold; the second call finds every map resident.
void gpuAgreement(int width, int height) {
  const NoisyRoom room(6, width, height);
  const FusionOptions checks = defaultConfidenceCalibration().checks;
  std::vector<FusionView> views;
  for (int i = 1; i < 6; ++i) views.push_back(room.view(i, {}, i));
  const FusionView reference = room.view(0, {}, 0);
  const AgreementCounts cpu = countAgreement(reference, views, checks);
  DepthMapFuser fuser(Backend::kCuda);
  const AgreementCounts gpu = fuser.countAgreement(reference, views, checks);
  const AgreementCounts again = fuser.countAgreement(reference, views, checks);
  size_t differing = 0, seen = 0, repeat = 0;
  for (size_t i = 0; i < cpu.seen.data.size(); ++i) {
    differing += cpu.seen.data[i] != gpu.seen.data[i] || cpu.agreeing.data[i] != gpu.agreeing.data[i];
    repeat += gpu.seen.data[i] != again.seen.data[i] || gpu.agreeing.data[i] != again.agreeing.data[i];
    seen += cpu.seen.data[i] > 0;
  }
  const FuserCacheStats stats = fuser.cacheStats();
  char text[300];
  std::snprintf(text, sizeof(text),
                "GPU agreement counts %dx%d: %zu pixels seen by another view, %.4f %% differ from the CPU "
                "(<= 0.05 %%), again identical: %s, uploads %lu, hits %lu, %.2f ms for both calls",
                width, height, seen, 100.0 * differing / cpu.seen.data.size(), repeat == 0 ? "yes" : "no",
                static_cast<unsigned long>(stats.uploads), static_cast<unsigned long>(stats.hits),
                fuser.times().agreement_ms);
  expect(seen > cpu.seen.data.size() / 2 && differing * 2000 <= cpu.seen.data.size() && repeat == 0 &&
             stats.uploads == 6 && stats.hits == 6,
         text);

  // The published depth and confidence computed on the GPU from those counts
  // (one kernel) equal the CPU's wherever the counts do.
  ConfidenceOptions options;
  const PublishedDepth cpu_published = publishDepth(reference, views, options);
  const PublishedDepth gpu_published = fuser.publishDepth(reference, views, options);
  size_t counts_differ = 0, values_differ = 0, published = 0;
  const auto same = [](float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  for (size_t i = 0; i < cpu.seen.data.size(); ++i) {
    counts_differ += gpu_published.counts.seen.data[i] != gpu.seen.data[i] ||
                     gpu_published.counts.agreeing.data[i] != gpu.agreeing.data[i];
    const bool counts_agree = cpu.seen.data[i] == gpu.seen.data[i] && cpu.agreeing.data[i] == gpu.agreeing.data[i];
    if (!counts_agree) continue;
    values_differ += !same(cpu_published.depth.data[i], gpu_published.depth.data[i]) ||
                     cpu_published.confidence.data[i] != gpu_published.confidence.data[i];
    published += std::isfinite(gpu_published.depth.data[i]);
  }
  std::snprintf(text, sizeof(text),
                "GPU published depth %dx%d at min_probability %.2f: %zu pixels published, counts as countAgreement's "
                "(%zu differ), depth and confidence as the CPU's where the counts agree (%zu differ)",
                width, height, options.min_probability, published, counts_differ, values_differ);
  expect(published > 0 && counts_differ == 0 && values_differ == 0 &&
             gpu_published.min_probability == options.min_probability,
         text);
}

// Fusion reading the estimator's outputs on the device (the pipeline's path:
// DepthEstimator::lastDeviceOutputs, DepthMapFuser::setDeviceSource) gives
// exactly the points of uploading the same depth map from the host; views
// that do not borrow those host images are uploaded as before.
void fusionFromEstimatorOutputs(const std::string& data, int max_image_size) {
  FountainImages fountain(data, max_image_size);
  DepthEstimator estimator(PatchMatchOptions(), Backend::kCuda);
  std::vector<DepthMap> maps;  // views 1, 2, then the reference 0 (the last estimate)
  std::vector<PinholeCamera> cameras;
  for (int id : {1, 2, 0}) {
    const DepthProblem problem = fountain.images.makeProblem(id);
    maps.push_back(estimator.estimate(problem));
    cameras.push_back(problem.reference_camera);
  }
  const DeviceDepthMap outputs = estimator.lastDeviceOutputs();
  const auto view = [&](int index, std::vector<int> sources, int64_t key) {
    FusionView v;
    v.id = index;
    v.camera = cameras[index];
    v.depth = maps[index].depth;
    v.normal = maps[index].normal;
    v.cost = maps[index].cost;
    v.source_ids = std::move(sources);
    v.key = key;
    return v;
  };
  // The reference (the last estimate) is view 2, checked against views 0 and 1.
  const std::vector<FusionView> views = {view(0, {}, 1), view(1, {}, 2), view(2, {0, 1}, 3)};
  const FusionOptions options = FusionOptions::reprojection();
  DepthMapFuser uploading(Backend::kCuda), copying(Backend::kCuda);
  copying.setDeviceSource(outputs);
  const FusionResult uploaded = uploading.fuse(views, options);
  const FusionResult copied = copying.fuse(views, options);
  const KeyframePoints& a = uploaded.views.back().points;
  const KeyframePoints& b = copied.views.back().points;
  bool identical = a.size() == b.size() && uploaded.candidate_pixels == copied.candidate_pixels;
  for (size_t i = 0; identical && i < a.size(); ++i) {
    identical = a[i].position == b[i].position && a[i].normal == b[i].normal && a[i].confidence == b[i].confidence &&
                a[i].consistent_views == b[i].consistent_views;
  }
  char text[300];
  std::snprintf(text, sizeof(text),
                "GPU fusion from the estimator's device outputs: %zu points, identical to uploading the map; "
                "device copies %lu of %lu uploads (the other views from the host)",
                b.size(), static_cast<unsigned long>(copying.cacheStats().device_copies),
                static_cast<unsigned long>(copying.cacheStats().uploads));
  expect(identical && a.size() > 100 && copying.cacheStats().device_copies == 1 &&
             copying.cacheStats().uploads == 3 && uploading.cacheStats().device_copies == 0 &&
             outputs.host_depth == maps.back().depth.data.data(),
         text);
}

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  using namespace amhmvs;
  if (argc < 2) {
    std::fprintf(stderr, "usage: amhmvs_gpu_tests DATA_DIR [--sanitize] [--skip-cpu-fountain]\n");
    return 2;
  }
  const std::string data = argv[1];
  bool sanitize = false, cpu_fountain = true;
  for (int i = 2; i < argc; ++i) {
    sanitize |= std::strcmp(argv[i], "--sanitize") == 0;
    if (std::strcmp(argv[i], "--skip-cpu-fountain") == 0) cpu_fountain = false;
  }
  std::string gpu;
  if (!cudaBackendAvailable(&gpu)) {
    std::printf("FAIL  no GPU: %s\n", gpu.c_str());
    return 1;
  }
  std::printf("device: %s\n", gpu.c_str());
  try {
    if (sanitize) {
      // Small scene for compute-sanitizer: two iterations on a 96 px image.
      const OwnedDepthProblem owned = loadProblem(data + "/mvsnet/fountain_x0.25", 0, 4, 96);
      const DepthProblem& problem = owned.problem;
      PatchMatchOptions options;
      options.num_iterations = 4;
      const DepthMap map = run(problem, Backend::kCuda, options);
      expect(map.depth.width == problem.reference_camera.width, "sanitizer scene ran");
      // Two scales (160 px: the coarser one is 80 px wide), the finer
      // scale's start carried on the device.
      PatchMatchOptions two_scales = options;
      two_scales.multiscale_levels = 2;
      const OwnedDepthProblem larger = loadProblem(data + "/mvsnet/fountain_x0.25", 0, 2, 160);
      expect(run(larger.problem, Backend::kCuda, two_scales).depth.width == 160, "sanitizer: two scales ran");
      // The resident pool's paths too: keyed images, a pool that grows
      // (copying its layers), evictions and a keyed reference.
      FountainImages fountain(data, 96);
      EstimatorResources resources;
      resources.device_image_budget_bytes = 6 * 96 * 64;
      DepthEstimator pooled(options, Backend::kCuda, resources), pooled_two_scales(two_scales, Backend::kCuda, resources);
      for (int id : {0, 1, 2, 3, 9, 10}) {
        const DepthProblem keyed = fountain.images.makeProblem(id);
        pooled.estimate(keyed);
        pooled_two_scales.estimate(keyed);  // the coarser copies' pool too
      }
      expect(pooled.deviceCacheStats().evictions > 0 && pooled_two_scales.deviceCacheStats().evictions > 0,
             "sanitizer: resident pools with evictions ran (one and two scales)");
      gpuFusion(96, 72);
      gpuAgreement(96, 72);
      depthFilterAgreement(96, 72);
      fusionFromEstimatorOutputs(data, 96);
      return failures ? 1 : 0;
    }
    textureEmulation();
    std::printf("INFO  peak bilinear fetch rate (8-bit layered texture, cache-resident): %.3g fetches/s\n",
                measureBilinearFetchRate());
    determinism(data);
    residentPool(data);
    gpuFusion(640, 480);
    gpuAgreement(640, 480);
    depthFilterAgreement(320, 240);
    depthFilterAgreement(640, 480);
    fusionFromEstimatorOutputs(data, 384);
    middlebury(data, Backend::kCuda, true);
    middlebury(data, Backend::kCpu, false);
    middleburyGeometric(data);
    middleburyMultiscale(data);
    middleburyPlanarPrior(data);
    coarseToFineCarriedOnDevice(data);
    coarserCopiesPool(data);
    pipelineTwoScalesWithFusionOverlap(data);
    for (const char* name : {"fountain_x0.25", "fountain_x1"}) {
      if (std::ifstream(data + "/mvsnet/" + name + "/pair.txt")) geometricSpeed(data, name);
    }
    fountain(data, Backend::kCuda);
    onlineMapperFountain(data);
    if (cpu_fountain) fountain(data, Backend::kCpu);
  } catch (const std::exception& e) {
    std::printf("FAIL  exception: %s\n", e.what());
    ++failures;
  }
  std::printf("%d failure(s)\n", failures);
  return failures ? 1 : 0;
}
