#include "amhmvs_mapping/ros/source_views.h"

#include <cmath>
#include <sstream>

namespace amhmvs_mapping {

std::string SourceViewOptions::validate() const {
  std::ostringstream out;
  if (num_sources < 1 || num_sources > 32) out << "num_sources " << num_sources << " is not in [1, 32]\n";
  if (!(min_baseline >= 0) || !std::isfinite(min_baseline))
    out << "min_baseline " << min_baseline << " must be finite and >= 0\n";
  if (!(max_baseline > min_baseline) || !std::isfinite(max_baseline))
    out << "max_baseline " << max_baseline << " must be finite and > min_baseline\n";
  if (!(max_angle_deg > 0 && max_angle_deg <= 180))
    out << "max_angle_deg " << max_angle_deg << " is not in (0, 180]\n";
  return out.str();
}

std::vector<size_t> chooseSourceViews(const amhmvs::PinholeCamera& target,
                                      const std::vector<const amhmvs::PinholeCamera*>& stored,
                                      const SourceViewOptions& options) {
  std::vector<size_t> chosen;
  const Eigen::Vector3d center = target.center();
  const Eigen::Vector3d axis = target.viewingDirection().normalized();
  const double cos_max = std::cos(options.max_angle_deg * M_PI / 180.0);
  for (size_t k = stored.size(); k-- > 0 && static_cast<int>(chosen.size()) < options.num_sources;) {
    const amhmvs::PinholeCamera* camera = stored[k];
    if (camera == nullptr || !camera->validate().empty()) continue;
    const double baseline = (camera->center() - center).norm();
    if (!(baseline >= options.min_baseline && baseline <= options.max_baseline)) continue;
    const double cos_angle = camera->viewingDirection().normalized().dot(axis);
    if (!(cos_angle >= cos_max)) continue;
    chosen.push_back(k);
  }
  return chosen;
}

}  // namespace amhmvs_mapping
