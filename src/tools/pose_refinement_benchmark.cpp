#include "pose_refinement_benchmark.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "synthetic_problem.h"

namespace amhmvs {
namespace {

double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// The tracker's error of source i: 12 mm and 0.5 degrees in a direction of its own.
PinholeCamera withTrackerError(const PinholeCamera& camera, int i) {
  Eigen::Isometry3d pose = cameraToWorld(camera);
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 0.5 * i, 2 - i).normalized();
  pose.linear() = pose.linear() * Eigen::AngleAxisd(0.5 * M_PI / 180, axis).matrix();
  pose.translation() += 0.012 * Eigen::Vector3d(1 - 0.5 * i, 1, 0.3 * i).normalized();
  PinholeCamera moved = camera;
  setCameraToWorld(pose, &moved);
  return moved;
}

struct Timing {
  double total = 0, features = 0, matching = 0, solve = 0;
};

}  // namespace

std::string poseRefinementTable(int runs) {
  std::ostringstream out;
  out << "\n## Pose refinement, folded planes, 4 sources 12 mm / 0.5 deg off (CPU)\n\n";
  if (!PoseRefiner::available()) return out.str() + PoseRefiner::unavailableMessage() + "\n";
  out << "| size | keyframe | median ms | features ms | matching ms | bundle adjustment ms | sources refined |\n"
      << "|---|---|---|---|---|---|---|\n";
  for (const auto& size : {std::make_pair(320, 240), std::make_pair(640, 480)}) {
    SyntheticProblem scene = makeSyntheticProblem(size.first, size.second, 4);
    const std::vector<PinholeCamera> tracker = [&] {
      std::vector<PinholeCamera> cameras;
      for (int i = 0; i < 4; ++i) cameras.push_back(withTrackerError(scene.problem.source_cameras[i], i));
      return cameras;
    }();
    scene.problem.reference_key = 0;
    scene.problem.source_keys = {1, 2, 3, 4};
    for (const bool online : {false, true}) {
      PoseRefiner refiner{PoseRefinementOptions()};
      std::vector<Timing> timings;
      int refined = 0;
      for (int run = 0; run <= runs; ++run) {  // run 0: warm-up (fills the cache when online)
        if (online) refiner.forget(0);  // a new keyframe: its own features are detected
        else refiner.forgetAll();
        DepthProblem problem = scene.problem;
        problem.source_cameras = tracker;
        const PoseRefinementResult result = refiner.refine(&problem);
        refined = result.refinedCount();
        if (run > 0) timings.push_back({result.total_ms, result.feature_ms, result.matching_ms, result.solve_ms});
      }
      auto stage = [&timings](double Timing::*field) {
        std::vector<double> values;
        for (const Timing& timing : timings) values.push_back(timing.*field);
        return median(values);
      };
      char row[256];
      std::snprintf(row, sizeof(row), "| %dx%d | %s | %.1f | %.1f | %.1f | %.1f | %d of 4 |\n", size.first,
                    size.second, online ? "online (sources cached)" : "first (5 images detected)",
                    stage(&Timing::total), stage(&Timing::features), stage(&Timing::matching),
                    stage(&Timing::solve), refined);
      out << row;
    }
  }
  return out.str();
}

}  // namespace amhmvs
