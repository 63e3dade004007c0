#include "amhmvs_mapping/mapping/undistortion.h"

#include <cmath>

namespace amhmvs {
namespace {

struct ModelInfo {
  const char* name;
  DistortionModel model;
  size_t coefficients;
};
const ModelInfo kModels[] = {{"plumb_bob", DistortionModel::kPlumbBob, 5},
                             {"rational_polynomial", DistortionModel::kRationalPolynomial, 8},
                             {"equidistant", DistortionModel::kEquidistant, 4}};

double coefficient(const Distortion& d, size_t i) { return i < d.coefficients.size() ? d.coefficients[i] : 0.0; }

}  // namespace

bool Distortion::isZero() const {
  for (double c : coefficients)
    if (c != 0) return false;
  return true;
}

std::string parseDistortion(const std::string& model, const std::vector<double>& d, Distortion* distortion) {
  const std::string name = model.empty() ? "plumb_bob" : model;
  for (const ModelInfo& info : kModels) {
    if (name != info.name) continue;
    if (d.size() > info.coefficients)
      return "distortion model " + name + " has " + std::to_string(info.coefficients) + " coefficients, D has " +
             std::to_string(d.size());
    for (double c : d)
      if (!std::isfinite(c)) return "distortion coefficient is not finite";
    distortion->model = info.model;
    distortion->coefficients = d;
    distortion->coefficients.resize(info.coefficients, 0.0);
    return "";
  }
  return "distortion model '" + model + "' is not plumb_bob, rational_polynomial or equidistant";
}

Eigen::Vector2d distortNormalized(const Distortion& d, const Eigen::Vector2d& ideal) {
  const double x = ideal.x(), y = ideal.y(), r2 = x * x + y * y;
  auto k = [&d](size_t i) { return coefficient(d, i); };
  if (d.model == DistortionModel::kEquidistant) {
    const double r = std::sqrt(r2);
    if (r < 1e-12) return ideal;
    const double theta = std::atan(r), t2 = theta * theta;
    const double theta_d = theta * (1 + t2 * (k(0) + t2 * (k(1) + t2 * (k(2) + t2 * k(3)))));
    return ideal * (theta_d / r);
  }
  const double radial = (1 + r2 * (k(0) + r2 * (k(1) + r2 * k(4)))) / (1 + r2 * (k(5) + r2 * (k(6) + r2 * k(7))));
  const double p1 = k(2), p2 = k(3);
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

}  // namespace amhmvs
