#include "amhmvs_mapping/mapping/rolling_shutter.h"

#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/image_remap.h"

namespace amhmvs {

std::string RollingShutterOptions::validate() const {
  std::ostringstream out;
  if (!(readout_s >= 0 && readout_s <= 1)) out << "readout_s must be in [0, 1] seconds, got " << readout_s << "\n";
  if (!(max_interval_s > 0 && std::isfinite(max_interval_s)))
    out << "max_interval_s must be positive and finite, got " << max_interval_s << "\n";
  return out.str();
}

Eigen::Vector3d cameraAngularVelocity(const PinholeCamera& earlier, const PinholeCamera& later, double seconds) {
  // Camera-to-world rotations are the transposes of PinholeCamera::R:
  // R_prev^T R in camera-to-world terms (the turn in the camera's own frame).
  const Eigen::AngleAxisd turn(Eigen::Matrix3d(earlier.R * later.R.transpose()));
  return turn.angle() * turn.axis() / seconds;
}

ImageU8 rectifyRollingShutter(const ImageU8& image, const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity,
                              double readout_s) {
  const double speed = angular_velocity.norm();
  if (readout_s <= 0 || speed <= 0 || image.height < 2) return image;
  const Eigen::Vector3d axis = angular_velocity / speed;
  // A few iterations of the row fixed point: each moves y' by the image
  // motion during the previous change of y', a small fraction of a pixel.
  constexpr int kIterations = 4;
  const auto rolling_shutter_position = [&](int u, int v, double* su, double* sv) {
    const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
    double row = v;
    Eigen::Vector3d seen = ray;
    for (int i = 0; i < kIterations; ++i) {
      const double row_time = readout_s * (row / (image.height - 1) - 0.5);
      seen = Eigen::AngleAxisd(-speed * row_time, axis) * ray;
      row = camera.fy * seen.y() / seen.z() + camera.cy;
    }
    *su = camera.fx * seen.x() / seen.z() + camera.cx;
    *sv = row;
  };
  return remapBilinear(image, rolling_shutter_position, RemapBorder::kClamp);
}

}  // namespace amhmvs
