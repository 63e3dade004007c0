// amhmvs_benchmark: time per depth map on real and synthetic scenes.
//
// GPU times are CUDA-event times inside the estimator, medians of --runs runs
// after one warm-up: "ms" from the images in device memory to depth, normal
// and cost in host memory (kernels and download), "with upload ms" from the
// images in host memory. CPU times use steady_clock with the given thread
// count (both columns equal).
//
// usage: amhmvs_benchmark [DATA_DIR] [--out FILE] [--runs N] [--cpu-threads N] [--quick]
//                         [--only SCENE]   (fountain_x0.25 ... fountain_x1, synthetic,
//                                           scaling, cpu; for profiling)
// The scaling rows time the synthetic scene at 4 sizes x 3 source counts.
// DATA_DIR holds mvsnet/fountain_x0.25, fountain_x0.5, fountain_x1 dense
// folders with decodable images (see scripts/prepare_gpu_data.py); rows whose
// folder is missing are skipped.
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "amhmvs_mapping/mvs/depth_estimator.h"
#include "depth_job.h"
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
            int iterations, int runs, int threads) {
#ifdef _OPENMP
  if (backend == Backend::kCpu) omp_set_num_threads(threads);
#endif
  PatchMatchOptions options;
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

}  // namespace
}  // namespace amhmvs

int main(int argc, char** argv) {
  using namespace amhmvs;
  std::string data, out_path = "benchmark.md";
  int runs = 5, cpu_threads = 2;
  bool quick = false;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
      continue;
    }
    if (a == "--out" && i + 1 < argc) out_path = argv[++i];
    else if (a == "--runs" && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--cpu-threads" && i + 1 < argc) cpu_threads = std::max(1, std::atoi(argv[++i]));
    else if (a == "--quick") quick = true;
    else data = a;
  }
  std::string device;
  const bool gpu = cudaBackendAvailable(&device);
  std::vector<Row> rows;
  try {
    if (gpu) {
      for (const char* name : {"fountain_x0.25", "fountain_x0.5", "fountain_x1"}) {
        const std::string folder = data + "/mvsnet/" + name;
        if (data.empty() || !exists(folder) || (!only.empty() && only != name)) continue;
        const Scene scene = readInputFolder(folder, 10);
        const OwnedDepthProblem owned = makeDepthProblem(scene, 5, ProblemOptions());
        for (int iterations : {6, 3}) rows.push_back(measure(name, owned.problem, Backend::kCuda, iterations, runs, 0));
        std::fprintf(stderr, "%s done\n", name);
      }
      if (only.empty() || only == "synthetic") {
        const SyntheticProblem vga = makeSyntheticProblem(640, 480, 4);
        for (int iterations : {6, 3}) {
          rows.push_back(measure("synthetic", vga.problem, Backend::kCuda, iterations, runs, 0));
        }
      }
    }
    if (gpu && (only.empty() || only == "scaling")) {
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
    if (only.empty() || only == "cpu") {
      const SyntheticProblem qvga = makeSyntheticProblem(320, 240, 4);
      rows.push_back(measure("synthetic", qvga.problem, Backend::kCpu, 6, quick ? 1 : runs, cpu_threads));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "amhmvs_benchmark: %s\n", e.what());
    return 1;
  }

  std::ostringstream table;
  table << "device: " << (gpu ? device : "none (CPU only)") << "\n\n"
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
  std::printf("%s", table.str().c_str());
  std::ofstream(out_path) << table.str();
  return 0;
}
