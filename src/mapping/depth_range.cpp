#include "amhmvs_mapping/mapping/depth_range.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

// Percentile p in [0, 100] of non-empty `values`, linear interpolation.
double interpolatedPercentile(std::vector<double>& values, double p) {
  const double position = p / 100.0 * (values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(values.size() - 1, below + 1);
  std::nth_element(values.begin(), values.begin() + below, values.end());
  const double low = values[below];
  double high = low;
  if (above != below) {
    high = *std::min_element(values.begin() + above, values.end());
  }
  return low + (position - below) * (high - low);
}

// Widened percentile range of `depths` (percentiles low/high_percentile);
// false (with `why`) when it is not a finite 0 < min < max range.
bool rangeFromSamples(std::vector<double>& depths, const DepthRangeOptions& options,
                      DepthRangeEstimate* estimate, std::string* why, double low_percentile,
                      double high_percentile) {
  const double low = interpolatedPercentile(depths, low_percentile);
  const double high = interpolatedPercentile(depths, high_percentile);
  const double min = low * options.near_factor;
  const double max = high * options.far_factor;
  if (!(std::isfinite(min) && std::isfinite(max) && min > 0 && min < max)) {
    std::ostringstream out;
    out << "percentiles give an unusable range [" << min << ", " << max << "]";
    *why = out.str();
    return false;
  }
  estimate->min = min;
  estimate->max = max;
  estimate->samples = depths.size();
  return true;
}

bool rangeFromSamples(std::vector<double>& depths, const DepthRangeOptions& options,
                      DepthRangeEstimate* estimate, std::string* why) {
  return rangeFromSamples(depths, options, estimate, why, options.low_percentile, options.high_percentile);
}

std::string rangeText(double min, double max) {
  std::ostringstream out;
  out.precision(4);
  out << "[" << min << ", " << max << "] m";
  return out.str();
}

// Appends the z-depth of `point` (camera frame) when the camera sees it:
// finite, in front and inside the image.
void addDepthIfSeen(const PinholeCamera& camera, const Eigen::Vector3d& point,
                    std::vector<double>* depths) {
  if (point.allFinite() && point.z() > 0 && camera.contains(camera.project(point))) {
    depths->push_back(point.z());
  }
}

}  // namespace

const char* depthRangeSourceName(DepthRangeSource source) {
  switch (source) {
    case DepthRangeSource::kGiven: return "given";
    case DepthRangeSource::kSparsePoints: return "sparse points";
    case DepthRangeSource::kNeighbourDepthMaps: return "neighbour depth maps";
    case DepthRangeSource::kMatchedPatches: return "matched patches";
    case DepthRangeSource::kDefault: return "default";
  }
  return "?";
}

std::string DepthRangeOptions::validate() const {
  std::ostringstream why;
  if (!(low_percentile >= 0 && low_percentile < high_percentile && high_percentile <= 100)) {
    why << "percentiles must satisfy 0 <= low < high <= 100 (got " << low_percentile << ", "
        << high_percentile << ")\n";
  }
  if (!(near_factor > 0 && near_factor <= 1)) {
    why << "near_factor must be in (0, 1] (got " << near_factor << ")\n";
  }
  if (!(std::isfinite(far_factor) && far_factor >= 1)) {
    why << "far_factor must be finite and >= 1 (got " << far_factor << ")\n";
  }
  if (!(neighbour_low_percentile >= 0 && neighbour_low_percentile < neighbour_high_percentile &&
        neighbour_high_percentile <= 100)) {
    why << "neighbour percentiles must satisfy 0 <= low < high <= 100 (got " << neighbour_low_percentile << ", "
        << neighbour_high_percentile << ")\n";
  }
  if (!(max_neighbour_cost >= 0)) why << "max_neighbour_cost must be >= 0 (got " << max_neighbour_cost << ")\n";
  if (min_sparse_points < 1) why << "min_sparse_points must be positive\n";
  if (min_depth_samples < 1) why << "min_depth_samples must be positive\n";
  if (depth_map_stride < 1) why << "depth_map_stride must be positive\n";
  if (min_matched_points < 1) why << "min_matched_points must be positive\n";
  std::istringstream matching_lines(matching.validate());
  for (std::string line; std::getline(matching_lines, line);) why << "matching: " << line << "\n";
  if (!(std::isfinite(default_min) && std::isfinite(default_max) && default_min > 0 &&
        default_min < default_max)) {
    why << "default range must be finite with 0 < min < max (got " << default_min << ", "
        << default_max << ")\n";
  }
  return why.str();
}

DepthRangeEstimate estimateDepthRange(const Keyframe& keyframe,
                                      const std::vector<NeighbourDepth>& neighbours,
                                      const DepthRangeOptions& options) {
  const std::string options_problem = options.validate();
  if (!options_problem.empty()) throw InputError("depth range options: " + options_problem);
  const std::string name = "keyframe " + std::to_string(keyframe.id);
  const std::string camera_problem = keyframe.camera.validate();
  if (!camera_problem.empty()) {
    throw InputError("depth range: " + name + ": camera: " + camera_problem);
  }
  const PinholeCamera& camera = keyframe.camera;
  DepthRangeEstimate estimate;
  std::ostringstream tried;  // why earlier rules did not apply

  // 1. Given range.
  if (options.use_given_range && keyframe.hasDepthRange()) {
    if (std::isfinite(keyframe.depth_max) && keyframe.depth_min < keyframe.depth_max) {
      estimate.min = keyframe.depth_min;
      estimate.max = keyframe.depth_max;
      estimate.source = DepthRangeSource::kGiven;
      estimate.reason = "given with the keyframe " + rangeText(estimate.min, estimate.max);
      return estimate;
    }
    tried << "given range " << rangeText(keyframe.depth_min, keyframe.depth_max)
          << " is unusable; ";
  }

  // 2. Sparse points in front of the camera and inside the image.
  std::vector<double> depths;
  for (const Eigen::Vector3d& world : keyframe.sparse_points) {
    addDepthIfSeen(camera, camera.toCamera(world), &depths);
  }
  if (static_cast<int>(depths.size()) >= options.min_sparse_points) {
    std::string why;
    if (rangeFromSamples(depths, options, &estimate, &why)) {
      estimate.source = DepthRangeSource::kSparsePoints;
      estimate.reason = tried.str() + "from " + std::to_string(depths.size()) +
                        " sparse points in view " + rangeText(estimate.min, estimate.max);
      return estimate;
    }
    tried << "sparse points: " << why << "; ";
  } else {
    tried << depths.size() << " sparse points in view < " << options.min_sparse_points << "; ";
  }

  // 3. Finished depth maps of overlapping keyframes, reprojected: confident
  // pixels, or every valid one when too few are confident.
  depths.clear();
  std::vector<double> unconfident;
  for (const NeighbourDepth& neighbour : neighbours) {
    const std::string neighbour_name = "neighbour keyframe " + std::to_string(neighbour.id);
    if (neighbour.camera == nullptr || neighbour.depth == nullptr) {
      throw InputError("depth range: " + name + ": " + neighbour_name +
                       ": null camera or depth map");
    }
    const PinholeCamera& other = *neighbour.camera;
    const ImageF& depth = *neighbour.depth;
    const std::string other_problem = other.validate();
    if (!other_problem.empty()) {
      throw InputError("depth range: " + name + ": " + neighbour_name +
                       ": camera: " + other_problem);
    }
    if (!depth.sameSize(other.width, other.height) || depth.channels != 1 ||
        depth.data.size() != depth.pixelCount()) {
      std::ostringstream why;
      why << "depth range: " << name << ": " << neighbour_name << ": depth map is " << depth.width
          << "x" << depth.height << "x" << depth.channels << " but its camera is " << other.width
          << "x" << other.height << "x1";
      throw InputError(why.str());
    }
    const ImageF* cost = neighbour.cost;
    if (cost != nullptr && (!cost->sameSize(depth.width, depth.height) || cost->channels != 1)) {
      throw InputError("depth range: " + name + ": " + neighbour_name + ": cost image does not match its depth map");
    }
    const RelativePose to_target = relativePose(other, camera);
    for (int y = 0; y < depth.height; y += options.depth_map_stride) {
      for (int x = 0; x < depth.width; x += options.depth_map_stride) {
        const double d = depth.at(x, y);
        if (!(std::isfinite(d) && d > 0)) continue;
        // NaN cost (nothing scored) is not confident either.
        const bool confident = cost == nullptr || cost->at(x, y) <= options.max_neighbour_cost;
        addDepthIfSeen(camera, to_target.R * other.backproject(x, y, d) + to_target.t,
                       confident ? &depths : &unconfident);
      }
    }
  }
  std::string which = "confident ";
  if (static_cast<int>(depths.size()) < options.min_depth_samples) {
    which = "(too few confident: " + std::to_string(depths.size()) + ") ";
    depths.insert(depths.end(), unconfident.begin(), unconfident.end());
  }
  if (static_cast<int>(depths.size()) >= options.min_depth_samples) {
    std::string why;
    if (rangeFromSamples(depths, options, &estimate, &why, options.neighbour_low_percentile,
                         options.neighbour_high_percentile)) {
      estimate.source = DepthRangeSource::kNeighbourDepthMaps;
      estimate.reason = tried.str() + "from " + std::to_string(depths.size()) + " " + which +
                        "depth samples of " + std::to_string(neighbours.size()) +
                        " neighbour depth maps " + rangeText(estimate.min, estimate.max);
      return estimate;
    }
    tried << "neighbour depth maps: " << why << "; ";
  } else {
    tried << depths.size() << " depth samples from " << neighbours.size()
          << " neighbour depth maps < " << options.min_depth_samples << "; ";
  }

  // 4. Default.
  estimate.min = options.default_min;
  estimate.max = options.default_max;
  estimate.source = DepthRangeSource::kDefault;
  estimate.samples = 0;
  estimate.reason = tried.str() + "default " + rangeText(estimate.min, estimate.max);
  return estimate;
}

DepthRangeEstimate estimateDepthRange(const KeyframeStore& store, int64_t id,
                                      const std::vector<int64_t>& neighbour_ids,
                                      const DepthRangeOptions& options) {
  const Keyframe& keyframe = store.keyframe(id);
  std::vector<NeighbourDepth> neighbours;
  for (int64_t neighbour_id : neighbour_ids) {
    if (neighbour_id == id) continue;
    const StoredKeyframe& stored = store.entry(neighbour_id);
    if (stored.depth->depth.empty()) continue;
    const ImageF* cost = stored.depth->cost.empty() ? nullptr : &stored.depth->cost;
    neighbours.push_back({neighbour_id, &stored.keyframe.camera, &stored.depth->depth, cost});
  }
  DepthRangeEstimate estimate = estimateDepthRange(keyframe, neighbours, options);
  if (estimate.source != DepthRangeSource::kDefault || !options.match_when_unknown) return estimate;

  // 4. Nothing measured yet: patches matched in the neighbours' images.
  std::vector<double> depths;
  for (int64_t neighbour_id : neighbour_ids) {
    if (neighbour_id == id) continue;
    const StoredKeyframe& neighbour = store.entry(neighbour_id);
    const std::vector<double> matched = matchDepthsAlongEpipolarLines(
        keyframe.camera, store.entry(id).grayImage(), neighbour.keyframe.camera, neighbour.grayImage(),
        options.matching);
    depths.insert(depths.end(), matched.begin(), matched.end());
  }
  std::string why;
  if (static_cast<int>(depths.size()) < options.min_matched_points) {
    why = std::to_string(depths.size()) + " matched depths < " + std::to_string(options.min_matched_points);
  } else if (rangeFromSamples(depths, options, &estimate, &why)) {
    estimate.source = DepthRangeSource::kMatchedPatches;
    estimate.reason = "no depth map or sparse point yet; from " + std::to_string(depths.size()) +
                      " depths matched along epipolar lines " + rangeText(estimate.min, estimate.max);
    return estimate;
  }
  estimate.reason = "matched patches: " + why + "; " + estimate.reason;
  return estimate;
}

}  // namespace amhmvs
