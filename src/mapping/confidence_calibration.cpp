#include "amhmvs_mapping/mapping/confidence_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

int ConfidenceCalibration::costBin(float cost) const {
  int bin = 0;
  while (bin < static_cast<int>(cost_edges.size()) && !(cost < cost_edges[bin])) ++bin;
  return bin;
}

size_t ConfidenceCalibration::cell(int seen, int agreeing, int bin) const {
  const int views = max_views + 1;
  return (static_cast<size_t>(seen) * views + agreeing) * costBins() + bin;
}

float ConfidenceCalibration::lookup(int seen, int agreeing, float cost) const {
  seen = std::min(std::max(seen, 0), max_views);
  agreeing = std::min(std::max(agreeing, 0), seen);
  return probability[cell(seen, agreeing, costBin(cost))];
}

std::string ConfidenceCalibration::validate() const {
  std::ostringstream why;
  const std::string checks_problem = checks.validate();
  if (!checks_problem.empty()) why << "checks: " << checks_problem << "\n";
  if (!(within > 0)) why << "within must be > 0 (got " << within << ")\n";
  if (max_views < 1 || max_views > 32) why << "max_views must be in [1, 32] (got " << max_views << ")\n";
  if (!std::is_sorted(cost_edges.begin(), cost_edges.end())) why << "cost_edges must be ascending\n";
  if (max_views >= 1 && max_views <= 32 && probability.size() != cellCount())
    why << "probability has " << probability.size() << " cells, expected " << cellCount() << "\n";
  for (float p : probability) {
    if (!(p >= 0 && p <= 1)) {
      why << "probabilities must be in [0, 1] (got " << p << ")\n";
      break;
    }
  }
  return why.str();
}

ConfidenceFit::ConfidenceFit(const ConfidenceCalibration& shape)
    : shape_(shape), samples_(shape.cellCount(), 0), within_(shape.cellCount(), 0) {}

void ConfidenceFit::add(int seen, int agreeing, float cost, double relative_error) {
  seen = std::min(std::max(seen, 0), shape_.max_views);
  agreeing = std::min(std::max(agreeing, 0), seen);
  const size_t cell = shape_.cell(seen, agreeing, shape_.costBin(cost));
  ++samples_[cell];
  within_[cell] += relative_error < shape_.within;
}

void ConfidenceFit::merge(const ConfidenceFit& other) {
  if (other.samples_.size() != samples_.size()) throw InputError("confidence fit: tables of different shapes");
  for (size_t i = 0; i < samples_.size(); ++i) {
    samples_[i] += other.samples_[i];
    within_[i] += other.within_[i];
  }
}

ConfidenceCalibration ConfidenceFit::table() const {
  ConfidenceCalibration table = shape_;
  table.probability.assign(shape_.cellCount(), 0.5f);
  for (size_t i = 0; i < samples_.size(); ++i) {
    table.probability[i] = static_cast<float>((within_[i] + 1.0) / (samples_[i] + 2.0));
  }
  return table;
}

std::string calibrationSource(const ConfidenceFit& fit) {
  const ConfidenceCalibration table = fit.table();
  const ConfidenceCalibration& shape = fit.shape();
  std::ostringstream out;
  char text[64];
  for (int seen = 0; seen <= shape.max_views; ++seen) {
    for (int agreeing = 0; agreeing <= shape.max_views; ++agreeing) {
      std::ostringstream counts;
      out << "      ";
      for (int bin = 0; bin < shape.costBins(); ++bin) {
        const size_t cell = shape.cell(seen, agreeing, bin);
        std::snprintf(text, sizeof(text), "%.3ff,", table.probability[cell]);
        out << text << (bin + 1 < shape.costBins() ? " " : "");
        counts << (bin ? " " : "") << fit.samples(cell);
      }
      out << "  // seen " << seen << ", agreeing " << agreeing << ": " << counts.str() << " samples\n";
    }
  }
  return out.str();
}

namespace {

// Fitted by (the command and its data are in the README, "Confidence and the
// published depth"):
//   PLACEHOLDER
ConfidenceCalibration committedCalibration() {
  ConfidenceCalibration c;
  c.checks = FusionOptions::reprojection();
  c.checks.max_normal_angle_deg = FusionOptions::kOff;
  c.within = 0.05;
  c.max_views = 4;
  c.cost_edges = {0.2f, 0.4f, 0.6f};
  c.probability.assign(c.cellCount(), 0.5f);
  return c;
}

}  // namespace

const ConfidenceCalibration& defaultConfidenceCalibration() {
  static const ConfidenceCalibration calibration = [] {
    ConfidenceCalibration c = committedCalibration();
    const std::string problem = c.validate();
    if (!problem.empty()) throw InputError("confidence calibration: " + problem);
    return c;
  }();
  return calibration;
}

}  // namespace amhmvs
