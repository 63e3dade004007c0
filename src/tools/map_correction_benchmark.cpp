#include "map_correction_benchmark.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <sstream>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/core/stopwatch.h"
#include "amhmvs_mapping/mapping/keyframe_pose_graph.h"
#include "amhmvs_mapping/mapping/rolling_shutter.h"

namespace amhmvs {
namespace {

// Median wall-clock milliseconds of `work` over `runs` calls after one warm-up.
double medianMs(int runs, const std::function<void()>& work) {
  work();
  std::vector<double> times;
  for (int run = 0; run < runs; ++run) {
    const auto start = std::chrono::steady_clock::now();
    work();
    times.push_back(millisecondsSince(start));
  }
  return medianOf(times);
}

Eigen::Isometry3d pose(const Eigen::Vector3d& turn, const Eigen::Vector3d& centre) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
  out.translation() = centre;
  return out;
}

}  // namespace

std::string mapCorrectionTable(int runs) {
  std::ostringstream out;
  out << "\n## Map corrections for real trackers, per keyframe (CPU)\n\n"
      << "| work | size | median ms |\n|---|---|---|\n";
  char row[160];
  for (const auto& size : {std::make_pair(320, 240), std::make_pair(640, 480)}) {
    ImageU8 image(size.first, size.second, 3);
    for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = static_cast<uint8_t>((i * 2654435761u) >> 24);
    PinholeCamera camera;
    camera.width = size.first;
    camera.height = size.second;
    camera.fx = camera.fy = 0.8 * size.first;
    camera.cx = 0.5 * size.first - 0.5;
    camera.cy = 0.5 * size.second - 0.5;
    const double ms = medianMs(runs, [&] { rectifyRollingShutter(image, camera, {0.1, 0.4, 0.05}, 0.025); });
    std::snprintf(row, sizeof(row), "| rolling-shutter rectification, RGB | %dx%d | %.2f |\n", size.first, size.second,
                  ms);
    out << row;
  }
  for (const int keyframes : {10, 50}) {
    // A curving walk, the tracker a few mm and tenths of a degree off it;
    // each keyframe refined against the three before it.
    const auto truth = [](int64_t id) {
      return pose({0.01, 0.05 * id + 0.01, 0}, {0.25 * std::cos(0.1 * id), 0.25 * id, 0});
    };
    std::map<int64_t, Eigen::Isometry3d> tracker;
    std::vector<KeyframePoseGraphEdge> edges;
    for (int64_t id = 0; id < keyframes; ++id) {
      tracker[id] = pose({0.003 * std::sin(id), 0.004 * std::cos(3.0 * id), 0.002}, {0.01 * std::sin(7.0 * id), 0, 0}) *
                    truth(id);
      for (int64_t back = 1; back <= 3 && back <= id; ++back)
        edges.push_back({id, id - back, truth(id - back).inverse() * truth(id)});
    }
    const double ms =
        keyframePoseGraphAvailable()
            ? medianMs(runs, [&] { solveKeyframePoseGraph(tracker, edges, KeyframePoseGraphSettings()); })
            : NAN;
    std::snprintf(row, sizeof(row), "| keyframe pose graph solve, 3 pairs per keyframe | %d keyframes | %.2f |\n",
                  keyframes, ms);
    out << row;
  }
  return out.str();
}

}  // namespace amhmvs
