#include "amhmvs_mapping/mapping/scene_depth.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/median.h"

namespace amhmvs {
namespace {

// Depth-map samples per image side (rules 3 and 4): enough for a median,
// cheap for a store of 50 keyframes.
constexpr int kDepthSamplesPerSide = 48;

bool usable(double depth) { return std::isfinite(depth) && depth > 0; }

void addDepthIfSeen(const PinholeCamera& camera, const Eigen::Vector3d& point, std::vector<double>* depths) {
  if (point.allFinite() && point.z() > 0 && camera.contains(camera.project(point))) depths->push_back(point.z());
}

// Calls visit(x, y, depth) for the valid depths of a grid of pixels.
template <typename Visit>
void forSampledDepths(const ImageF& depth, Visit visit) {
  if (depth.empty()) return;
  const int step_x = std::max(1, depth.width / kDepthSamplesPerSide);
  const int step_y = std::max(1, depth.height / kDepthSamplesPerSide);
  for (int y = step_y / 2; y < depth.height; y += step_y)
    for (int x = step_x / 2; x < depth.width; x += step_x)
      if (usable(depth.at(x, y))) visit(x, y, static_cast<double>(depth.at(x, y)));
}

SceneDepth median(const std::vector<double>& depths, const std::string& what) {
  return {medianOf(depths), "median of " + std::to_string(depths.size()) + " " + what};
}

// Rule 1 and 2; depth 0 when neither applies.
SceneDepth fromKeyframe(const Keyframe& keyframe, const SceneDepthOptions& options, size_t* points_in_view) {
  std::vector<double> depths;
  for (const Eigen::Vector3d& world : keyframe.sparse_points)
    addDepthIfSeen(keyframe.camera, keyframe.camera.toCamera(world), &depths);
  *points_in_view = depths.size();
  if (static_cast<int>(depths.size()) >= options.min_sparse_points) return median(depths, "sparse points");
  const double middle = 0.5 * (keyframe.depth_min + keyframe.depth_max);
  if (keyframe.hasDepthRange() && usable(middle)) return {middle, "middle of the depth range"};
  return {};
}

// Sorts `ids` by the distance of their keyframe's centre from `centre`
// (ties by id).
void sortByDistance(const KeyframeStore& store, const Eigen::Vector3d& centre, std::vector<int64_t>* ids) {
  std::vector<std::pair<double, int64_t>> keyed;
  keyed.reserve(ids->size());
  for (int64_t id : *ids) keyed.emplace_back((store.keyframe(id).camera.center() - centre).norm(), id);
  std::sort(keyed.begin(), keyed.end());
  for (size_t i = 0; i < keyed.size(); ++i) (*ids)[i] = keyed[i].second;
}

// Rule 4: the depth maps of the nearest other keyframes that look the same
// way, reprojected into `camera` (a few views give a median; more would make
// the cost grow with the store).
std::vector<double> reprojectedDepths(const KeyframeStore& store, const PinholeCamera& camera,
                                      std::vector<int64_t> other_ids) {
  constexpr int kViews = 8;
  sortByDistance(store, camera.center(), &other_ids);
  std::vector<double> depths;
  int views = 0;
  for (int64_t other : other_ids) {
    if (views >= kViews) break;
    const StoredKeyframe& stored = store.entry(other);
    const PinholeCamera& other_camera = stored.keyframe.camera;
    if (!stored.depth->depth.sameSize(other_camera.width, other_camera.height)) continue;
    if (other_camera.viewingDirection().dot(camera.viewingDirection()) <= 0) continue;
    ++views;
    const RelativePose to_target = relativePose(other_camera, camera);
    forSampledDepths(stored.depth->depth, [&](int x, int y, double d) {
      addDepthIfSeen(camera, to_target.R * other_camera.backproject(x, y, d) + to_target.t, &depths);
    });
  }
  return depths;
}

// Rule 5: depths matched along epipolar lines in the nearest other keyframes.
std::vector<double> matchedDepths(const KeyframeStore& store, int64_t id, std::vector<int64_t> other_ids,
                                  const SceneDepthOptions& options) {
  const StoredKeyframe& target = store.entry(id);
  const Eigen::Vector3d centre = target.keyframe.camera.center();
  const auto distance = [&](int64_t other) { return (store.keyframe(other).camera.center() - centre).norm(); };
  sortByDistance(store, centre, &other_ids);
  std::vector<double> depths;
  int views = 0;
  for (int64_t other : other_ids) {
    if (views >= options.max_match_views) break;
    if (distance(other) < 1e-9) continue;  // no baseline: nothing to triangulate
    ++views;
    const StoredKeyframe& source = store.entry(other);
    const std::vector<double> matched = matchDepthsAlongEpipolarLines(
        target.keyframe.camera, target.grayImage(), source.keyframe.camera, source.grayImage(), options.matching);
    depths.insert(depths.end(), matched.begin(), matched.end());
  }
  return depths;
}

SceneDepth fallback(const SceneDepthOptions& options, const std::string& why) {
  return {options.default_scene_depth, "default (" + why + ")"};
}

}  // namespace

std::string SceneDepthOptions::validate() const {
  std::ostringstream why;
  if (min_sparse_points < 1) why << "min_sparse_points must be positive\n";
  if (min_depth_samples < 1) why << "min_depth_samples must be positive\n";
  if (max_match_views < 1) why << "max_match_views must be positive\n";
  if (min_matched_points < 1) why << "min_matched_points must be positive\n";
  if (!(std::isfinite(default_scene_depth) && default_scene_depth > 0))
    why << "default_scene_depth must be positive and finite (got " << default_scene_depth << ")\n";
  std::istringstream lines(matching.validate());
  for (std::string line; std::getline(lines, line);) why << "matching: " << line << "\n";
  return why.str();
}

SceneDepth sceneDepth(const Keyframe& keyframe, const SceneDepthOptions& options) {
  size_t points_in_view = 0;
  const SceneDepth own = fromKeyframe(keyframe, options, &points_in_view);
  if (usable(own.depth)) return own;
  return fallback(options, std::to_string(points_in_view) + " sparse points in view, no depth range");
}

SceneDepth sceneDepth(const KeyframeStore& store, int64_t id, const std::vector<int64_t>& other_ids,
                      const SceneDepthOptions& options) {
  const StoredKeyframe& stored = store.entry(id);
  size_t points_in_view = 0;
  const SceneDepth own = fromKeyframe(stored.keyframe, options, &points_in_view);
  if (usable(own.depth)) return own;

  std::vector<double> depths;
  forSampledDepths(stored.depth->depth, [&](int, int, double d) { depths.push_back(d); });
  if (static_cast<int>(depths.size()) >= options.min_depth_samples)
    return median(depths, "depths of its own depth map");

  depths = reprojectedDepths(store, stored.keyframe.camera, other_ids);
  if (static_cast<int>(depths.size()) >= options.min_depth_samples)
    return median(depths, "depths of other keyframes' depth maps in view");
  std::ostringstream why;
  why << points_in_view << " sparse points in view, no depth range, " << depths.size()
      << " reprojected depths";

  if (options.match_when_unknown) {
    depths = matchedDepths(store, id, other_ids, options);
    if (static_cast<int>(depths.size()) >= options.min_matched_points)
      return median(depths, "depths matched along epipolar lines");
    why << ", " << depths.size() << " matched depths";
  }
  return fallback(options, why.str());
}

}  // namespace amhmvs
