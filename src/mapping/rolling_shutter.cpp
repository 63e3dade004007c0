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

namespace {

// The rolling shutter of one turning camera: the ray that the row exposed at
// time t(row) sees for a ray d of the middle row's orientation,
// Exp(-w t(row)) d.
class TurningRows {
 public:
  TurningRows(const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity, double readout_s)
      : camera_(camera), readout_s_(readout_s), speed_(angular_velocity.norm()) {
    axis_ = speed_ > 0 ? Eigen::Vector3d(angular_velocity / speed_) : Eigen::Vector3d::UnitZ();
    seconds_per_row_ = camera.height > 1 ? readout_s / (camera.height - 1) : 0;
  }

  double rowTime(double row) const { return row * seconds_per_row_ - 0.5 * readout_s_; }

  // Exp(-w t(row)) ray, by Rodrigues' formula; the angles of a readout are
  // small, so sin and cos by their series (error below 1e-9 rad under
  // 0.05 rad), else exactly.
  Eigen::Vector3d turned(const Eigen::Vector3d& ray, double row) const {
    const double angle = -speed_ * rowTime(row);
    const double squared = angle * angle;
    const bool small = std::abs(angle) < 0.05;
    const double sine = small ? angle * (1 - squared / 6) : std::sin(angle);
    const double one_minus_cosine = small ? squared * (0.5 - squared / 24) : 1 - std::cos(angle);
    return ray * (1 - one_minus_cosine) + axis_.cross(ray) * sine + axis_ * (axis_.dot(ray) * one_minus_cosine);
  }

  // The ray the rolling shutter saw for `ray`, and its row: the fixed point
  // row = row of Exp(-w t(row)) ray. Each iteration changes the row by the
  // image motion during the previous change, a few pixels over a readout
  // of hundreds of rows (a factor ~0.01 per iteration): after two, far
  // below 0.01 px.
  Eigen::Vector3d seen(const Eigen::Vector3d& ray, double row, double* seen_row) const {
    constexpr int kIterations = 2;
    Eigen::Vector3d seen = ray;
    for (int i = 0; i < kIterations; ++i) {
      seen = turned(ray, row);
      row = camera_.fy * seen.y() / seen.z() + camera_.cy;
    }
    *seen_row = row;
    return seen;
  }

 private:
  const PinholeCamera& camera_;
  double readout_s_, speed_, seconds_per_row_;
  Eigen::Vector3d axis_;
};

}  // namespace

ImageU8 rectifyRollingShutter(const ImageU8& image, const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity,
                              double readout_s) {
  if (readout_s <= 0 || !(angular_velocity.norm() > 0) || image.height < 2) return image;
  const TurningRows rows(camera, angular_velocity, readout_s);
  const auto rolling_shutter_position = [&](int u, int v, double* su, double* sv) {
    const Eigen::Vector3d seen = rows.seen(camera.backproject(u, v, 1.0), v, sv);
    *su = camera.fx * seen.x() / seen.z() + camera.cx;
  };
  return remapBilinear(image, rolling_shutter_position, RemapBorder::kClamp);
}

}  // namespace amhmvs
