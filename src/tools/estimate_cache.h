// Depth maps of a pipeline run kept for the next run of the same sequence
// with other fusion or confidence options (amhmvs_map_study): those change
// nothing the estimator sees, so the same problems come again and are
// answered from the cache (memory, and a folder of PFM files when given).
#pragma once

#include <map>
#include <memory>
#include <string>

#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

class EstimateCache {
 public:
  // `dir` empty: memory only. Throws InputError when the folder cannot be made.
  EstimateCache(const PatchMatchOptions& options, Backend backend, const std::string& dir);
  // The cached depth map of this problem (keyed by its image keys, depth range
  // and size), else the estimator's.
  DepthMap estimate(const DepthProblem& problem);
  size_t hits() const { return hits_; }
  size_t misses() const { return misses_; }

 private:
  std::unique_ptr<DepthEstimator> estimator_;  // created at the first miss
  PatchMatchOptions options_;
  Backend backend_;
  std::string dir_;
  std::map<std::string, DepthMap> memory_;
  size_t hits_ = 0, misses_ = 0;
};

}  // namespace amhmvs
