// Session 26: mapping/keyframe_bundle_adjustment.h on the features, sizes and
// matches that `session26_coarse_features.py export` writes; prints each
// keyframe's adjusted camera-to-world pose (id and 16 numbers, row-major),
// which `session26_coarse_features.py pairs --poses DATA:FILE` compares with
// the truth. Arguments after the file: finest_feature_size_px (default 0)
// and min_explained_rms_px (default 0.25; 0 moves keyframes started at the
// true poses as well, instead of confirming them).
// Session 28, from the environment: VELOCITIES=FILE (an MVSNet velocities.txt)
// and READOUT=SECONDS give each keyframe its rolling shutter's linear velocity
// (each feature seen from its row's centre, as the pipeline with
// --rolling_shutter_velocity=1); PRIOR_ROT (degrees) and PRIOR_POS (metres)
// replace the tracker prior's sigmas; VELOCITY_SIGMA_RAD_S and
// VELOCITY_SIGMA_M_S solve each keyframe's velocity too (VelocityPrior).
// Features for it from images rectified
// with the same velocities: session28_rectify_with_velocities.cpp.
// Build against the dev build's core:
//   g++ -O2 -std=c++17 -Iinclude -I/usr/include/eigen3 tools/research/session26_adjust_keyframes.cpp \
//       -Lbuild_cpu/devel/lib -lamhmvs_core -o /tmp/adjust_keyframes
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "amhmvs_mapping/mapping/keyframe_bundle_adjustment.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"

int main(int argc, char** argv) {
  using namespace amhmvs;
  if (argc < 2) {
    std::cerr << "usage: adjust_keyframes FILE [finest_feature_size_px [min_explained_rms_px]]\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  std::map<int64_t, BundleKeyframe> keyframes;
  std::vector<KeyframeFeatureMatches> matches;
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    std::string tag;
    int64_t key = 0;
    int count = 0;
    fields >> tag;
    if (tag == "K") {  // id, size, intrinsics, world-to-camera [R | t] row-major
      BundleKeyframe keyframe;
      PinholeCamera& camera = keyframe.camera;
      fields >> key >> camera.width >> camera.height >> camera.fx >> camera.fy >> camera.cx >> camera.cy;
      for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col) fields >> camera.R(row, col);
        fields >> camera.t(row);
      }
      keyframes[key] = keyframe;
    } else if (tag == "F") {  // pixels
      fields >> key >> count;
      for (int i = 0; i < count; ++i) {
        double x = 0, y = 0;
        fields >> x >> y;
        keyframes[key].pixels.emplace_back(x, y);
      }
    } else if (tag == "S") {  // sizes
      fields >> key >> count;
      keyframes[key].sizes.resize(count);
      for (double& size : keyframes[key].sizes) fields >> size;
    } else if (tag == "M") {  // matched feature pairs of two keyframes
      KeyframeFeatureMatches pair;
      fields >> pair.first >> pair.second >> count;
      pair.features.resize(count);
      for (auto& match : pair.features) fields >> match.first >> match.second;
      matches.push_back(pair);
    }
  }
  if (const char* vel = std::getenv("VELOCITIES")) {
    const char* readout_text = std::getenv("READOUT");
    const double readout = readout_text ? std::atof(readout_text) : 0;
    for (auto& [id, v] : readMvsnetVelocities(vel)) {
      if (!keyframes.count(id)) continue;
      keyframes[id].motion.velocity = v.linear;
      keyframes[id].motion.readout_s = readout;
    }
  }
  KeyframeBundleAdjustmentSettings settings;
  if (const char* p = std::getenv("PRIOR_POS")) settings.prior_position_sigma_m = std::atof(p);
  if (const char* p = std::getenv("PRIOR_ROT")) settings.prior_rotation_sigma_rad = std::atof(p) * M_PI / 180;
  // VELOCITY_SIGMA_RAD_S and VELOCITY_SIGMA_M_S (both): each keyframe's
  // velocity solved too, with these as the noise of the given velocities.
  const char* angular_sigma = std::getenv("VELOCITY_SIGMA_RAD_S");
  const char* linear_sigma = std::getenv("VELOCITY_SIGMA_M_S");
  for (auto& entry : keyframes) {
    if (angular_sigma && linear_sigma)
      entry.second.velocity = {std::atof(angular_sigma), std::atof(linear_sigma), CameraVelocity()};
  }
  if (argc > 2) settings.finest_feature_size_px = std::atof(argv[2]);
  if (argc > 3) settings.min_explained_rms_px = std::atof(argv[3]);
  const KeyframeBundleAdjustmentResult result = adjustKeyframes(keyframes, matches, settings);
  std::cerr << "solved " << result.solved << ", tracks " << result.tracks << ", confirmed " << result.confirmed
            << ", rms " << result.rms_before_px << " -> " << result.rms_after_px << " px\n";
  for (const auto& [id, correction] : result.velocity_corrections)
    std::cerr << "velocity correction " << id << ": " << correction.angular.transpose() << " rad/s, "
              << correction.linear.transpose() << " m/s\n";
  std::cout << std::setprecision(17);
  for (const auto& [id, pose] : result.poses) {
    std::cout << id;
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) std::cout << ' ' << pose.matrix()(row, col);
    std::cout << '\n';
  }
  return result.solved ? 0 : 1;
}
