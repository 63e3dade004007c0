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

ImageU8 rectifyRollingShutter(const ImageU8& image, const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity,
                              double readout_s) {
  const double speed = angular_velocity.norm();
  if (readout_s <= 0 || speed <= 0 || image.height < 2) return image;
  const Eigen::Vector3d axis = angular_velocity / speed;
  // Iterations of the row fixed point: each changes y' by the image motion
  // during the previous change, a few pixels over a readout of hundreds of
  // rows (a factor ~0.01 per iteration): after two, far below 0.01 px.
  constexpr int kIterations = 2;
  const double seconds_per_row = readout_s / (image.height - 1);
  const auto rolling_shutter_position = [&](int u, int v, double* su, double* sv) {
    const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
    const Eigen::Vector3d axis_cross_ray = axis.cross(ray);
    const double axis_dot_ray = axis.dot(ray);
    double row = v;
    Eigen::Vector3d seen = ray;
    for (int i = 0; i < kIterations; ++i) {
      // Rodrigues' formula for Exp(-w t(row)) ray; the angles of a readout
      // are small, so sin and cos by their series (error below 1e-9 rad
      // under 0.05 rad), else exactly.
      const double angle = -speed * (row * seconds_per_row - 0.5 * readout_s);
      const double squared = angle * angle;
      const bool small = std::abs(angle) < 0.05;
      const double sine = small ? angle * (1 - squared / 6) : std::sin(angle);
      const double one_minus_cosine = small ? squared * (0.5 - squared / 24) : 1 - std::cos(angle);
      seen = ray * (1 - one_minus_cosine) + axis_cross_ray * sine + axis * (axis_dot_ray * one_minus_cosine);
      row = camera.fy * seen.y() / seen.z() + camera.cy;
    }
    *su = camera.fx * seen.x() / seen.z() + camera.cx;
    *sv = row;
  };
  return remapBilinear(image, rolling_shutter_position, RemapBorder::kClamp);
}

}  // namespace amhmvs
