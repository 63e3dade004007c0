#include "depth_job.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <future>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/stopwatch.h"
#include "amhmvs_mapping/eval/depth_metrics.h"
#include "amhmvs_mapping/eval/ground_truth_depth.h"
#include "amhmvs_mapping/io/background_writer.h"
#include "amhmvs_mapping/io/colmap_model.h"
#include "amhmvs_mapping/io/depth_preview.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "tool_options.h"

namespace amhmvs {
namespace {


bool isDirectory(const std::string& path) {
  struct stat info;
  return stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

void makeDirectories(const std::string& path) {
  for (size_t pos = 1; pos <= path.size(); ++pos) {
    if (pos == path.size() || path[pos] == '/') {
      const std::string prefix = path.substr(0, pos);
      if (!isDirectory(prefix) && mkdir(prefix.c_str(), 0755) != 0 && !isDirectory(prefix)) {
        // errno says why: a file in the way, no permission, a read-only file
        // system, a missing parent.
        const std::string why =
            errno == EEXIST ? "a file that is not a directory is in the way" : std::strerror(errno);
        throw InputError(prefix + ": cannot create directory (" + why + ")");
      }
    }
  }
}

std::string viewFolderName(int view_id) {
  char name[16];
  std::snprintf(name, sizeof(name), "%08d", view_id);
  return name;
}

// Every view at its processed size, and every reference view with the depth
// range it will use, checked before any work: a problem names the view id
// (the estimator would only know "source view <index>") and nothing is written.
void checkViewsBeforeEstimating(const Scene& scene, const std::vector<int>& reference_ids,
                                const ProblemOptions& options) {
  for (const SceneView& view : scene.views) {
    int width, height;
    scaledSize(view.camera.width, view.camera.height, options, &width, &height);
    const std::string why = view.camera.resized(width, height).validate();
    if (!why.empty()) {
      throw InputError("view " + std::to_string(view.id) + " (" + view.image_path + ") at " +
                       std::to_string(width) + "x" + std::to_string(height) + ": " + why);
    }
  }
  if (options.depth_min <= 0) return;  // the views' own ranges were checked at load
  for (const int id : reference_ids) {
    const int index = scene.indexOf(id);
    if (index < 0) continue;  // reported by makeDepthProblem
    const std::string why =
        conditioningProblem(scene.views[index].camera, options.depth_min, options.depth_max);
    if (!why.empty()) {
      throw InputError("view " + std::to_string(id) + " with --depth_min/--depth_max: " + why);
    }
  }
}

}  // namespace

Scene readInputFolder(const std::string& dir, int max_sources) {
  if (!isDirectory(dir)) throw InputError(dir + ": input folder does not exist");
  if (isDirectory(dir + "/sparse")) {
    ColmapOptions colmap;
    colmap.max_sources = max_sources;
    return readColmapWorkspace(dir, colmap);
  }
  if (isDirectory(dir + "/cams")) return readMvsnetDenseFolder(dir);
  throw InputError(dir + ": neither an MVSNet dense folder (images/, cams/, pair.txt) nor a "
                   "COLMAP workspace (sparse/, images/)");
}

void maskByCost(DepthMap* map, float max_cost) {
  for (size_t i = 0; i < map->depth.data.size(); ++i) {
    if (!(map->cost.data[i] <= max_cost)) map->depth.data[i] = std::nanf("");
  }
}

namespace {

// The files of one depth map as independent jobs (any order, any thread):
// depth.pfm, normal.pfm, cost.pfm, depth.png, cam.txt in `dir`.
std::vector<std::function<void()>> depthOutputJobs(const std::string& dir, const PinholeCamera& camera,
                                                   double depth_min, double depth_max,
                                                   std::shared_ptr<const DepthMap> map) {
  std::vector<std::function<void()>> jobs;
  jobs.push_back([dir, map] { writePfm(dir + "/depth.pfm", map->depth); });
  jobs.push_back([dir, map] { writePfm(dir + "/normal.pfm", map->normal); });
  jobs.push_back([dir, map] { writePfm(dir + "/cost.pfm", map->cost); });
  jobs.push_back([dir, map, depth_min, depth_max] {
    // Colour scale from the map's own robust range, else the problem's range
    // (a map with no valid depth at all is shown black).
    writePng(dir + "/depth.png",
             depthPreview(map->depth, static_cast<float>(depth_min), static_cast<float>(depth_max)));
  });
  jobs.push_back([dir, camera, depth_min, depth_max] { writeMvsnetCam(dir + "/cam.txt", camera, depth_min, depth_max); });
  return jobs;
}

// Ground truth of view `id` sampled at width x height (nearest pixel):
// DIR/NNNNNNNN.pfm, or in a Middlebury 2014 scene folder (disp0GT.pfm) view
// 0's non-occluded depth (NaN elsewhere; the other views have none: false).
bool readGroundTruth(const std::string& dir, int id, int width, int height, ImageF* truth) {
  std::ifstream middlebury(dir + "/disp0GT.pfm");
  if (!middlebury.good()) {
    *truth = resampleNearest(readPfm(dir + "/" + viewFolderName(id) + ".pfm"), width, height);
    return true;
  }
  if (id != 0) return false;
  MiddleburyGroundTruth gt = readMiddleburyGroundTruth(dir);
  for (size_t p = 0; p < gt.depth.data.size(); ++p) {
    if (gt.nonoccluded.data[p] == 0) gt.depth.data[p] = std::nanf("");
  }
  *truth = resampleNearest(gt.depth, width, height);
  return true;
}

}  // namespace

void writeDepthOutputs(const std::string& output_dir, int view_id, const PinholeCamera& camera,
                       double depth_min, double depth_max, const DepthMap& map) {
  const std::string dir = output_dir + "/" + viewFolderName(view_id);
  makeDirectories(dir);
  // Borrowed for the calls below only (no-op deleter): no copy of the map.
  const std::shared_ptr<const DepthMap> borrowed(&map, [](const DepthMap*) {});
  for (const auto& job : depthOutputJobs(dir, camera, depth_min, depth_max, borrowed)) job();
}

void attachGeometricInputs(const std::map<int, DepthMap>& photometric, int reference_id, DepthProblem* problem) {
  for (int64_t source : problem->source_keys) {
    const auto found = photometric.find(static_cast<int>(source));
    problem->source_depths.push_back(found != photometric.end() ? ImageViewF(found->second.depth) : ImageViewF());
  }
  const DepthMap& own = photometric.at(reference_id);
  problem->prior_depth = own.depth;
  problem->prior_normal = own.normal;
}

void preferOneCudaWorkQueue() {
  // The default, 8 queues per context, cost on an H200 61 ms more at context
  // creation and 111 ms more from exec to exit of a minimal CUDA program
  // (docs/performance.md); they only help streams that run side by side.
  setenv("CUDA_DEVICE_MAX_CONNECTIONS", "1", /*overwrite=*/0);
}

int runDepthJob(const std::string& input_dir, const std::string& output_dir,
                const DepthJobOptions& options,
                const std::function<void(int, const DepthProblem&, const DepthMap&)>& on_result,
                const std::function<void(int, const DepthMap&)>& on_photometric) {
  using Clock = std::chrono::steady_clock;
  const auto job_start = Clock::now();
  // The GPU context starts (a few hundred ms) while the scene and the first
  // problem's images are read.
  std::future<std::unique_ptr<DepthEstimator>> starting = std::async(std::launch::async, [&options] {
    return std::make_unique<DepthEstimator>(options.patchmatch, options.backend);
  });
  const Scene scene = readInputFolder(input_dir, options.problem.max_sources);
  std::vector<int> ids = options.reference_ids;
  if (ids.empty()) {
    for (const SceneView& view : scene.views) {
      const auto it = scene.sources.find(view.id);
      if (it != scene.sources.end() && !it->second.empty()) ids.push_back(view.id);
    }
  }
  if (ids.empty()) throw InputError(input_dir + ": no view has source views");
  checkViewsBeforeEstimating(scene, ids, options.problem);
  // Each image is read once and, on the GPU, uploaded once (view ids are the
  // image keys); an image the cache drops leaves the device too.
  SceneImageCache images(scene, options.problem);
  DepthProblem first_problem = images.makeProblem(ids[0]);
  const double first_problem_ms = millisecondsSince(job_start);
  const std::unique_ptr<DepthEstimator> estimator_owner = starting.get();
  DepthEstimator& estimator = *estimator_owner;
  images.onDrop([&estimator](int64_t view_id) { estimator.forget(view_id); });
  const double startup_ms = millisecondsSince(job_start);
  if (!options.quiet) {
    std::string gpu;
    cudaBackendAvailable(&gpu);
    std::cerr << "amhmvs_depth: " << scene.views.size() << " views, " << ids.size()
              << " depth maps, backend " << backendName(estimator.backend())
              << (estimator.backend() == Backend::kCuda ? " on " + gpu : "") << "\n";
    if (options.backend == Backend::kAuto && estimator.backend() == Backend::kCpu) {
      std::cerr << "amhmvs_depth: " << gpu << ", running on the CPU\n";
    }
  }
  int written = 0;
  AccuracyCounts pooled;
  // Encoding and writing overlap the next estimate, one file per job on 4
  // threads; about two maps in the queue bound the memory (x1: 126 MB each).
  BackgroundWriter writer(10, 4);
  double problem_ms = first_problem_ms, estimate_ms = 0, writer_wait_ms = 0;
  // --geometric: the photometric maps of all listed views first (in memory).
  const bool geometric = options.geometric_iterations > 0;
  std::map<int, DepthMap> photometric;
  std::unique_ptr<DepthEstimator> geometric_estimator;
  if (geometric) {
    for (size_t i = 0; i < ids.size(); ++i) {
      auto start = Clock::now();
      const DepthProblem problem = i == 0 ? first_problem : images.makeProblem(ids[i]);
      problem_ms += millisecondsSince(start);
      start = Clock::now();
      photometric[ids[i]] = estimator.estimate(problem);
      estimate_ms += millisecondsSince(start);
      if (on_photometric) on_photometric(ids[i], photometric[ids[i]]);
    }
    PatchMatchOptions second = options.patchmatch;
    second.num_iterations = options.geometric_iterations;
    second.first_iteration = second.bisection_only_iterations;
    geometric_estimator = std::make_unique<DepthEstimator>(second, estimator.backend());
  }
  for (size_t i = 0; i < ids.size(); ++i) {
    auto start = Clock::now();
    DepthProblem problem = i == 0 && !geometric ? first_problem : images.makeProblem(ids[i]);
    if (i > 0 || geometric) problem_ms += millisecondsSince(start);
    if (geometric) attachGeometricInputs(photometric, ids[i], &problem);
    start = Clock::now();
    DepthMap map = geometric ? geometric_estimator->estimate(problem) : estimator.estimate(problem);
    estimate_ms += millisecondsSince(start);
    if (options.max_cost > 0) maskByCost(&map, options.max_cost);
    if (on_result) on_result(ids[i], problem, map);
    ++written;
    std::string accuracy;
    ImageF truth;
    if (!options.ground_truth_dir.empty() &&
        readGroundTruth(options.ground_truth_dir, ids[i], map.depth.width, map.depth.height, &truth)) {
      const AccuracyCounts counts = denseDepthAccuracy(map.depth, truth, nullptr);
      pooled.merge(counts);
      accuracy = ", within 1/2/5 % of ground truth: " + counts.percentages() + " %";
    }
    if (!options.quiet) {
      std::fprintf(stderr, "[%zu/%zu] view %s: %dx%d, %zu sources, depth [%.3g, %.3g] m, %.0f ms%s\n",
                   i + 1, ids.size(), viewFolderName(ids[i]).c_str(), problem.reference_camera.width,
                   problem.reference_camera.height, problem.source_cameras.size(), problem.depth_min,
                   problem.depth_max, map.milliseconds, accuracy.c_str());
    }
    if (!output_dir.empty()) {
      start = Clock::now();
      const std::string dir = output_dir + "/" + viewFolderName(ids[i]);
      makeDirectories(dir);
      for (auto& job : depthOutputJobs(dir, problem.reference_camera, problem.depth_min, problem.depth_max,
                                       std::make_shared<const DepthMap>(std::move(map)))) {
        writer.submit(std::move(job));
      }
      writer_wait_ms += millisecondsSince(start);
    }
  }
  auto start = Clock::now();
  writer.finish();  // a write error (naming its file) is thrown here
  writer_wait_ms += millisecondsSince(start);
  if (!options.quiet) {
    std::fprintf(stderr,
                 "amhmvs_depth: %.0f ms in all: %.0f until the estimator was ready (first problem's images read "
                 "after %.0f), %.0f building problems, %.0f estimating, %.0f waiting for the writer\n",
                 millisecondsSince(job_start), startup_ms, first_problem_ms, problem_ms, estimate_ms,
                 writer_wait_ms);
  }
  if (!options.ground_truth_dir.empty()) {
    std::fprintf(stderr, "depth accuracy over %d maps (%ld pixels): within 1/2/5 %%: %s %%\n",
                 written, pooled.total, pooled.percentages().c_str());
  }
  return written;
}

namespace {

std::vector<int> parseIdList(const std::string& text) {
  std::vector<int> ids;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const int id = parseValue<int>("views", item);
    if (id < 0) throw InputError("option --views: view id " + item + " is negative");
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) {
      throw InputError("option --views: view " + item + " is listed twice");
    }
    ids.push_back(id);
  }
  if (ids.empty()) throw InputError("option --views: no view id given");
  return ids;
}

// Values that parse but mean nothing: refused rather than silently ignored.
void checkOptionMeanings(const DepthJobOptions& options, bool depth_min_given,
                         bool depth_max_given) {
  const ProblemOptions& p = options.problem;
  if (depth_min_given != depth_max_given) {
    throw InputError("options --depth_min and --depth_max must be given together");
  }
  if (depth_min_given &&
      !(p.depth_min >= kMinDepth && p.depth_max <= kMaxDepth && p.depth_min < p.depth_max)) {
    std::ostringstream why;
    why << "invalid depth range: options --depth_min " << p.depth_min << " --depth_max " << p.depth_max
        << ": need " << kMinDepth << " <= depth_min < depth_max <= " << kMaxDepth;
    throw InputError(why.str());
  }
  // The estimator's window is 11x11 px by default: a smaller image has no
  // pixel whose window fits (the nodelet has the same floor).
  if (p.max_image_size != 0 && p.max_image_size < kMinMaxImageSize) {
    throw InputError("option --max_image_size " + std::to_string(p.max_image_size) +
                     ": must be 0 (no limit) or >= " + std::to_string(kMinMaxImageSize));
  }
  if (!(std::isfinite(options.max_cost) && options.max_cost >= 0)) {
    throw InputError("option --max_cost " + std::to_string(options.max_cost) +
                     ": must be > 0 (a cost threshold) or 0 (no mask)");
  }
}

}  // namespace

DepthJobOptions parseDepthJobArguments(const std::vector<std::string>& arguments) {
  DepthJobOptions options;
  bool depth_min_given = false, depth_max_given = false;
  bool geometric = false;
  int geometric_iterations = 3;
  for (size_t i = 0; i < arguments.size(); ++i) {
    std::string name, value;
    nextOption(arguments, &i, {"quiet", "geometric"}, &name, &value);
    if (name == "quiet") options.quiet = parseSwitch(name, value);
    else if (name == "geometric") geometric = parseSwitch(name, value);
    else if (name == "geometric_iterations") geometric_iterations = parseValue<int>(name, value);
    else if (name == "views") options.reference_ids = parseIdList(value);
    else if (name == "num_sources") options.problem.max_sources = parseValue<int>(name, value);
    else if (name == "max_image_size") options.problem.max_image_size = parseValue<int>(name, value);
    else if (name == "scale") options.problem.scale = parseValue<double>(name, value);
    else if (name == "depth_min") {
      options.problem.depth_min = parseValue<double>(name, value);
      depth_min_given = true;
    } else if (name == "depth_max") {
      options.problem.depth_max = parseValue<double>(name, value);
      depth_max_given = true;
    }
    else if (name == "backend") options.backend = parseBackend(value);
    else if (name == "max_cost") options.max_cost = parseValue<float>(name, value);
    else if (name == "ground_truth") options.ground_truth_dir = value;
    else if (!setPatchMatchOption(name, value, &options.patchmatch))
      throw InputError("unknown option --" + name + " (see --help)");
  }
  if (geometric_iterations < 1 || geometric_iterations > 100) {
    throw InputError("option --geometric_iterations must be in 1..100, got " + std::to_string(geometric_iterations));
  }
  options.geometric_iterations = geometric ? geometric_iterations : 0;
  checkOptionMeanings(options, depth_min_given, depth_max_given);
  const std::string problems = options.problem.validate() + options.patchmatch.validate();
  if (!problems.empty()) throw InputError("invalid options:\n" + problems);
  return options;
}

std::string depthJobUsage() {
  std::ostringstream out;
  out << "Usage: amhmvs_depth INPUT_DIR OUTPUT_DIR [options]\n\n"
         "Estimates a depth map per reference view with AMHMVS PatchMatch multi-view stereo.\n"
         "INPUT_DIR is an MVSNet dense folder (images/, cams/NNNNNNNN_cam.txt, pair.txt) or a\n"
         "COLMAP workspace (sparse/ with cameras, images, points3D as .txt or .bin, and images/;\n"
         "PINHOLE or SIMPLE_PINHOLE cameras, e.g. from `colmap image_undistorter`).\n\n"
         "Writes OUTPUT_DIR/<8-digit view id>/: depth.pfm (z-depth in metres, float32, at the\n"
         "processed resolution; NaN where nothing could be scored, or above --max_cost),\n"
         "normal.pfm (3 channels, camera frame), cost.pfm, depth.png (colour-mapped) and\n"
         "cam.txt (the camera used, MVSNet format, K scaled).\n\n"
         "Input options:\n"
         "  --views ID[,ID...]      reference views (default: every view with sources)\n"
         "  --num_sources N         source views per reference, best first (default 10, max 32)\n"
         "  --max_image_size N      longest image side after scaling, 0 = no limit (default 0)\n"
         "  --scale S               image scale in (0, 1] (default 1)\n"
         "  --depth_min M --depth_max M   override the views' depth ranges (metres)\n"
         "  --backend auto|cuda|cpu compute backend (default auto: CUDA if a GPU is usable)\n"
         "  --max_cost C            mask pixels whose cost exceeds C (default 0: no mask)\n"
         "  --ground_truth DIR      report accuracy against DIR/NNNNNNNN.pfm z-depth maps, or\n"
         "                          a Middlebury 2014 scene folder (view 0, non-occluded pixels)\n"
         "  --geometric             then a geometric-consistency pass per view (not in the paper):\n"
         "                          from its photometric map, with the reprojection error against\n"
         "                          the listed source views' maps added to every cost\n"
         "  --geometric_iterations N   iterations of that pass (default 3, numbered from\n"
         "                          bisection_only_iterations: local refinement)\n"
         "  --quiet                 no progress on stderr\n\n"
         "Method options (defaults are the paper's):\n"
      << describe(PatchMatchOptions())
      << "\nEnvironment: CUDA_DEVICE_MAX_CONNECTIONS is 1 unless you set it (one estimate at a\n"
         "time needs one CUDA work queue; the GPU context then starts and ends faster).\n";
  return out.str();
}

}  // namespace amhmvs
