#include "amhmvs_mapping/mapping/view_anchor.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/core/text.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {
namespace {

// "X,Y,Z" as a vector; false when it is not three finite numbers, not all zero.
bool parseDirection(const std::string& text, Eigen::Vector3d* direction) {
  std::vector<double> values;
  std::istringstream items(text);
  for (std::string item; std::getline(items, item, ',');) {
    const std::string number = trimmed(item);
    char* end = nullptr;
    const double value = std::strtod(number.c_str(), &end);
    if (number.empty() || *end != '\0' || !std::isfinite(value)) return false;
    values.push_back(value);
  }
  if (values.size() != 3) return false;
  *direction = Eigen::Vector3d(values[0], values[1], values[2]);
  return direction->norm() > 0;
}

}  // namespace

bool viewAnchor(const PinholeCamera& camera, const ImageF& depth, Eigen::Vector3d* anchor) {
  std::vector<double> valid;
  for (float d : depth.data)
    if (std::isfinite(d) && d > 0) valid.push_back(d);
  if (valid.empty()) return false;
  const Eigen::Isometry3d camera_to_world = cameraToWorld(camera);
  *anchor = camera_to_world * Eigen::Vector3d(0, 0, medianOf(valid));
  return true;
}

std::string validateViewUp(const std::string& setting) {
  Eigen::Vector3d direction;
  if (trimmed(setting) == "auto" || parseDirection(setting, &direction)) return "";
  return "view_up must be auto or X,Y,Z (three numbers, not all zero), not '" + setting + "'";
}

Eigen::Vector3d viewUp(const std::string& setting, const Eigen::Matrix3d& camera_to_world_rotation) {
  const std::string problem = validateViewUp(setting);
  if (!problem.empty()) throw InputError(problem);
  Eigen::Vector3d direction;
  if (parseDirection(setting, &direction)) return direction.normalized();
  const Eigen::Vector3d camera_up = -camera_to_world_rotation.col(1).normalized();
  if (camera_up.z() >= std::cos(kAutoUpMaxTiltDeg * M_PI / 180)) return Eigen::Vector3d::UnitZ();
  int axis = 0;
  camera_up.cwiseAbs().maxCoeff(&axis);
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  up[axis] = camera_up[axis] > 0 ? 1 : -1;
  return up;
}

Eigen::Quaterniond viewOrientation(const Eigen::Vector3d& up) {
  const Eigen::Vector3d unit = up.normalized();
  if (unit.z() < -1 + 1e-12) return Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), unit);
}

}  // namespace amhmvs
