#include "estimate_cache.h"

#include <cstdio>
#include <filesystem>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/pfm.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

std::string problemKey(const DepthProblem& problem) {
  char text[96];
  std::snprintf(text, sizeof(text), "%lld_%dx%d_%.9g_%.9g", static_cast<long long>(problem.reference_key),
                problem.reference_camera.width, problem.reference_camera.height, problem.depth_min,
                problem.depth_max);
  std::string key = text;
  for (int64_t source : problem.source_keys) key += "_" + std::to_string(source);
  return key;
}

}  // namespace

EstimateCache::EstimateCache(const PatchMatchOptions& options, Backend backend, const std::string& dir)
    : options_(options), backend_(backend), dir_(dir) {
  if (dir_.empty()) return;
  std::error_code error;
  fs::create_directories(dir_, error);
  if (error) throw InputError(dir_ + ": cannot create folder (" + error.message() + ")");
}

DepthMap EstimateCache::estimate(const DepthProblem& problem) {
  const std::string key = problemKey(problem);
  const auto found = memory_.find(key);
  if (found != memory_.end()) {
    ++hits_;
    return found->second;
  }
  const std::string stem = dir_.empty() ? "" : dir_ + "/" + key;
  DepthMap map;
  if (!stem.empty() && fs::exists(stem + ".cost.pfm")) {
    map.depth = readPfm(stem + ".depth.pfm");
    map.normal = readPfm(stem + ".normal.pfm");
    map.cost = readPfm(stem + ".cost.pfm");
    ++hits_;
  } else {
    if (!estimator_) estimator_.reset(new DepthEstimator(options_, backend_));
    map = estimator_->estimate(problem);
    ++misses_;
    if (!stem.empty()) {
      writePfm(stem + ".depth.pfm", map.depth);
      writePfm(stem + ".normal.pfm", map.normal);
      writePfm(stem + ".cost.pfm", map.cost);  // last: its presence marks a complete entry
    }
  }
  memory_[key] = map;
  return map;
}

}  // namespace amhmvs
