#include "amhmvs_mapping/mapping/source_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
// Below this baseline (relative to the scene depth; about 0.06 deg of
// triangulation angle) a pair is treated as pure rotation.
constexpr double kMinRelativeBaseline = 1e-3;

// Numbers for the rejection messages, without a stream (a large store
// rejects hundreds of candidates per selection).
std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

// Compact number for messages: "1", "0.3", "12.5".
std::string compact(double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.4g", value);
  return text;
}

double angleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double cosine = a.normalized().dot(b.normalized());
  return std::acos(std::max(-1.0, std::min(1.0, cosine))) * kRadToDeg;
}

double preferenceScore(double angle_deg, const SourceSelectionOptions& options) {
  const double sigma =
      angle_deg <= options.preferred_angle_deg ? options.sigma_below_deg : options.sigma_above_deg;
  const double diff = angle_deg - options.preferred_angle_deg;
  return std::exp(-diff * diff / (2 * sigma * sigma));
}

// The checks that need no grid: the candidate's camera, the baseline against
// pure rotation, the optical axes. Fills id, baseline_m and axis_angle_deg;
// the rejection is empty when the candidate passes.
SourceViewCandidate precheck(const Keyframe& target, double scene_depth, const Keyframe& candidate,
                             const SourceSelectionOptions& options) {
  SourceViewCandidate result;
  result.id = candidate.id;
  const std::string camera_problem = candidate.camera.validate();
  if (!camera_problem.empty()) {
    result.rejection = "invalid camera: " + camera_problem;
    return result;
  }
  result.baseline_m = (candidate.camera.center() - target.camera.center()).norm();
  result.axis_angle_deg =
      angleBetweenDeg(target.camera.viewingDirection(), candidate.camera.viewingDirection());
  if (result.baseline_m < kMinRelativeBaseline * scene_depth) {
    result.rejection =
        (result.axis_angle_deg < 0.01 ? "duplicate pose: baseline " : "pure rotation: baseline ") +
        fixed(result.baseline_m, 3) + " m at scene depth " + fixed(scene_depth, 2) + " m";
  } else if (result.axis_angle_deg > options.max_axis_angle_deg) {
    result.rejection = "optical axes " + fixed(result.axis_angle_deg, 0) + " deg apart > " +
                       compact(options.max_axis_angle_deg);
  }
  return result;
}

// The grid checks of a candidate that passed precheck(): overlap and
// triangulation angle, then the score.
SourceViewCandidate evaluate(const Keyframe& target, const std::vector<Eigen::Vector3d>& grid_world,
                             const Keyframe& candidate, SourceViewCandidate result,
                             const SourceSelectionOptions& options) {
  const Eigen::Vector3d target_centre = target.camera.center();
  const Eigen::Vector3d candidate_centre = candidate.camera.center();
  std::vector<double> angles;
  angles.reserve(grid_world.size());
  for (const Eigen::Vector3d& point : grid_world) {
    const Eigen::Vector3d in_candidate = candidate.camera.toCamera(point);
    if (in_candidate.z() <= 0 ||
        !candidate.camera.contains(candidate.camera.project(in_candidate))) {
      continue;
    }
    angles.push_back(triangulationAngle(target_centre, candidate_centre, point) * kRadToDeg);
  }
  result.overlap = static_cast<double>(angles.size()) / grid_world.size();
  // Without overlap, the angle at the middle of the grid still says something.
  const Eigen::Vector3d& middle = grid_world[grid_world.size() / 2];
  result.triangulation_angle_deg =
      angles.empty() ? triangulationAngle(target_centre, candidate_centre, middle) * kRadToDeg
                     : medianOf(angles);

  if (result.overlap < options.min_overlap) {
    result.rejection = "overlap " + fixed(100 * result.overlap, 0) + " % < " +
                       compact(100 * options.min_overlap) + " %";
  } else if (result.triangulation_angle_deg < options.min_triangulation_angle_deg) {
    result.rejection = "triangulation angle " + fixed(result.triangulation_angle_deg, 1) +
                       " deg < " + compact(options.min_triangulation_angle_deg);
  } else if (result.triangulation_angle_deg > options.max_triangulation_angle_deg) {
    result.rejection = "triangulation angle " + fixed(result.triangulation_angle_deg, 1) +
                       " deg > " + compact(options.max_triangulation_angle_deg);
  } else {
    result.score = result.overlap * preferenceScore(result.triangulation_angle_deg, options);
  }
  return result;
}

}  // namespace

std::string SourceSelectionOptions::validate() const {
  std::ostringstream why;
  const auto finite = [](double v) { return std::isfinite(v); };
  if (max_sources < 1 || max_sources > kMaxSourceViews) {
    why << "max_sources must be in [1, " << kMaxSourceViews << "] (got " << max_sources << ")\n";
  }
  if (!(finite(min_triangulation_angle_deg) && finite(max_triangulation_angle_deg) &&
        min_triangulation_angle_deg >= 0 &&
        min_triangulation_angle_deg < max_triangulation_angle_deg &&
        max_triangulation_angle_deg <= 180)) {
    why << "triangulation angles must satisfy 0 <= min < max <= 180 (got "
        << min_triangulation_angle_deg << ", " << max_triangulation_angle_deg << ")\n";
  }
  if (!(finite(max_axis_angle_deg) && max_axis_angle_deg > 0 && max_axis_angle_deg <= 180)) {
    why << "max_axis_angle_deg must be in (0, 180] (got " << max_axis_angle_deg << ")\n";
  }
  if (!(finite(min_overlap) && min_overlap > 0 && min_overlap <= 1)) {
    why << "min_overlap must be in (0, 1] (got " << min_overlap << ")\n";
  }
  if (!(finite(preferred_angle_deg) && preferred_angle_deg > 0)) {
    why << "preferred_angle_deg must be positive (got " << preferred_angle_deg << ")\n";
  }
  if (!(finite(sigma_below_deg) && finite(sigma_above_deg) && sigma_below_deg > 0 &&
        sigma_above_deg > 0)) {
    why << "sigma_below_deg and sigma_above_deg must be positive\n";
  }
  if (overlap_grid < 2 || overlap_grid > 1000) {
    why << "overlap_grid must be in [2, 1000] (got " << overlap_grid << ")\n";
  }
  if (max_candidates < max_sources) {
    why << "max_candidates must be at least max_sources (got " << max_candidates << " < " << max_sources << ")\n";
  }
  why << SceneDepthOptions::validate();
  return why.str();
}

namespace {

void requireValid(const Keyframe& target, const SourceSelectionOptions& options) {
  const std::string options_problem = options.validate();
  if (!options_problem.empty()) throw InputError("source selection options: " + options_problem);
  const std::string camera_problem = target.camera.validate();
  if (!camera_problem.empty()) {
    throw InputError("source selection: keyframe " + std::to_string(target.id) +
                     ": camera: " + camera_problem);
  }
}

SourceSelection selectAtDepth(const Keyframe& target, const std::vector<const Keyframe*>& candidates,
                              const SceneDepth& scene_depth, const SourceSelectionOptions& options) {
  SourceSelection selection;
  selection.scene_depth = scene_depth;
  const double depth = selection.scene_depth.depth;

  // Grid of target pixels at the scene depth, in the world frame.
  const PinholeCamera& camera = target.camera;
  std::vector<Eigen::Vector3d> grid_world;
  const int n = options.overlap_grid;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = (i + 0.5) * camera.width / n - 0.5;
      const double v = (j + 0.5) * camera.height / n - 0.5;
      grid_world.push_back(camera.R.transpose() * (camera.backproject(u, v, depth) - camera.t));
    }
  }

  std::vector<SourceViewCandidate> qualified, rejected;
  std::vector<std::pair<SourceViewCandidate, const Keyframe*>> passed;
  for (const Keyframe* candidate : candidates) {
    if (candidate == nullptr) {
      throw InputError("source selection: keyframe " + std::to_string(target.id) +
                       ": null candidate");
    }
    if (candidate->id == target.id) continue;
    SourceViewCandidate checked = precheck(target, depth, *candidate, options);
    if (checked.rejection.empty()) {
      passed.emplace_back(std::move(checked), candidate);
    } else {
      rejected.push_back(std::move(checked));
    }
  }
  if (static_cast<int>(passed.size()) > options.max_candidates) {
    // The ranking's own terms at one point, the target's centre pixel at the
    // scene depth: seen by the candidate first, then the triangulation
    // angle's distance from the preferred one in units of the ranking's sigma.
    const Eigen::Vector3d target_centre = camera.center();
    const Eigen::Vector3d ahead =
        camera.R.transpose() * (camera.backproject(0.5 * (camera.width - 1), 0.5 * (camera.height - 1), depth) - camera.t);
    const auto key = [&](const std::pair<SourceViewCandidate, const Keyframe*>& entry) {
      const PinholeCamera& other = entry.second->camera;
      const Eigen::Vector3d in_other = other.toCamera(ahead);
      const bool seen = in_other.z() > 0 && other.contains(other.project(in_other));
      const double angle = triangulationAngle(target_centre, other.center(), ahead) * kRadToDeg;
      const double sigma = angle <= options.preferred_angle_deg ? options.sigma_below_deg : options.sigma_above_deg;
      return std::make_pair(seen ? 0 : 1, std::abs(angle - options.preferred_angle_deg) / sigma);
    };
    std::vector<std::pair<std::pair<int, double>, size_t>> order;
    for (size_t i = 0; i < passed.size(); ++i) order.emplace_back(key(passed[i]), i);
    std::sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
      return a.first != b.first ? a.first < b.first : passed[a.second].first.id < passed[b.second].first.id;
    });
    std::vector<std::pair<SourceViewCandidate, const Keyframe*>> kept;
    for (size_t rank = 0; rank < order.size(); ++rank) {
      auto& entry = passed[order[rank].second];
      if (static_cast<int>(rank) < options.max_candidates) {
        kept.push_back(std::move(entry));
        continue;
      }
      entry.first.rejection = "not among the " + std::to_string(options.max_candidates) +
                              " candidates nearest the preferred angle at the image centre";
      rejected.push_back(std::move(entry.first));
    }
    passed.swap(kept);
  }
  for (auto& [checked, candidate] : passed) {
    SourceViewCandidate evaluated = evaluate(target, grid_world, *candidate, std::move(checked), options);
    (evaluated.rejection.empty() ? qualified : rejected).push_back(std::move(evaluated));
  }
  std::sort(qualified.begin(), qualified.end(),
            [](const SourceViewCandidate& a, const SourceViewCandidate& b) {
              return a.score != b.score ? a.score > b.score : a.id < b.id;
            });
  for (size_t rank = 0; rank < qualified.size(); ++rank) {
    if (static_cast<int>(rank) < options.max_sources) {
      selection.source_ids.push_back(qualified[rank].id);
    } else {
      qualified[rank].rejection = "rank " + std::to_string(rank + 1) + " of " +
                                  std::to_string(qualified.size()) + ": only " +
                                  std::to_string(options.max_sources) + " sources are kept";
    }
  }
  std::sort(rejected.begin(), rejected.end(),
            [](const SourceViewCandidate& a, const SourceViewCandidate& b) { return a.id < b.id; });
  selection.candidates = std::move(qualified);
  selection.candidates.insert(selection.candidates.end(), rejected.begin(), rejected.end());

  if (selection.source_ids.empty()) {
    std::ostringstream why;
    if (selection.candidates.empty()) {
      why << "keyframe " << target.id << ": no candidate keyframes to choose sources from";
    } else {
      why << "keyframe " << target.id << ": none of " << selection.candidates.size()
          << " candidates qualifies (scene depth " << fixed(depth, 2) << " m, "
          << selection.scene_depth.source << "):";
      for (const SourceViewCandidate& c : selection.candidates) {
        why << " keyframe " << c.id << ": " << c.rejection << ";";
      }
    }
    selection.reason = why.str();
  }
  return selection;
}

}  // namespace

SourceSelection selectSources(const Keyframe& target,
                              const std::vector<const Keyframe*>& candidates,
                              const SourceSelectionOptions& options) {
  requireValid(target, options);
  return selectAtDepth(target, candidates, sceneDepth(target, options), options);
}

SourceSelection selectSources(const KeyframeStore& store, int64_t target_id,
                              const std::vector<int64_t>& candidate_ids,
                              const SourceSelectionOptions& options) {
  const Keyframe& target = store.keyframe(target_id);
  requireValid(target, options);
  std::vector<int64_t> others;
  std::vector<const Keyframe*> candidates;
  for (int64_t id : candidate_ids) {
    if (id == target_id) continue;
    others.push_back(id);
    candidates.push_back(&store.keyframe(id));
  }
  return selectAtDepth(target, candidates, sceneDepth(store, target_id, others, options), options);
}

size_t nearestCandidateCount(const SourceSelectionOptions& options) {
  return 4 * static_cast<size_t>(std::max(options.max_candidates, 1));
}

SourceSelection selectSources(const KeyframeStore& store, int64_t target_id,
                              const SourceSelectionOptions& options) {
  const Eigen::Vector3d centre = store.keyframe(target_id).camera.center();
  return selectSources(store, target_id, store.nearestIds(centre, nearestCandidateCount(options), target_id), options);
}

}  // namespace amhmvs
