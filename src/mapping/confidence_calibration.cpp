#include "amhmvs_mapping/mapping/confidence_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

int ConfidenceCalibration::costBin(float cost) const { return view().costBin(cost); }

size_t ConfidenceCalibration::cell(int seen, int agreeing, int bin) const {
  return static_cast<size_t>(view().cell(seen, agreeing, bin));
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

// Fitted on a realism-mode room (12 views at 320x240, seed 2, the default
// profile with the pose error of a good tracker, about 1 px: the agreement
// means nothing at the default profile's 2.6 px, see the README) by
//   amhmvs_synthetic room12 --scene room --views 12 --seed 2 --realism default
//     (continued) --pose_noise_m 0.004 --pose_noise_deg 0.12 --pose_drift_m 0.002 --pose_drift_deg 0.04
//   amhmvs_map_study room12 OUT --backend cpu --max_image_size 320 --num_sources 4
// which writes these lines to OUT/calibration_fit.txt (the probability per
// cost bin, and how many pixels each cell had; cells without any are 0.5).
ConfidenceCalibration committedCalibration() {
  ConfidenceCalibration c;
  c.checks = FusionOptions::reprojection();
  c.checks.max_reprojection_error = 3.0f;
  c.checks.max_relative_depth_difference = 0.03f;
  c.checks.max_normal_angle_deg = FusionOptions::kOff;
  c.within = 0.05;
  c.max_views = 4;
  c.cost_edges = {0.2f, 0.4f, 0.6f};
  c.probability = {
      0.947f, 0.957f, 0.970f, 0.625f,  // seen 0, agreeing 0: 55 44 31 611 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 0, agreeing 1: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 0, agreeing 2: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 0, agreeing 3: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 0, agreeing 4: 0 0 0 0 samples
      0.779f, 0.773f, 0.742f, 0.260f,  // seen 1, agreeing 0: 3509 1954 761 1288 samples
      0.467f, 0.453f, 0.375f, 0.741f,  // seen 1, agreeing 1: 12425 1317 238 145 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 1, agreeing 2: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 1, agreeing 3: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 1, agreeing 4: 0 0 0 0 samples
      0.707f, 0.549f, 0.306f, 0.106f,  // seen 2, agreeing 0: 13335 6390 2909 3331 samples
      0.453f, 0.561f, 0.561f, 0.507f,  // seen 2, agreeing 1: 112370 8077 2092 682 samples
      0.899f, 0.838f, 0.714f, 0.659f,  // seen 2, agreeing 2: 19483 1216 278 39 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 2, agreeing 3: 0 0 0 0 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 2, agreeing 4: 0 0 0 0 samples
      0.871f, 0.692f, 0.403f, 0.068f,  // seen 3, agreeing 0: 3850 2507 681 645 samples
      0.975f, 0.983f, 0.963f, 0.845f,  // seen 3, agreeing 1: 8954 4912 653 95 samples
      0.998f, 0.985f, 0.949f, 0.889f,  // seen 3, agreeing 2: 5080 1495 176 16 samples
      1.000f, 0.998f, 0.964f, 0.909f,  // seen 3, agreeing 3: 3360 470 54 9 samples
      0.500f, 0.500f, 0.500f, 0.500f,  // seen 3, agreeing 4: 0 0 0 0 samples
      0.829f, 0.541f, 0.370f, 0.215f,  // seen 4, agreeing 0: 26910 35972 24236 15654 samples
      0.965f, 0.927f, 0.811f, 0.609f,  // seen 4, agreeing 1: 64129 52462 16444 4866 samples
      0.991f, 0.965f, 0.877f, 0.742f,  // seen 4, agreeing 2: 111840 57689 14591 2925 samples
      0.991f, 0.981f, 0.930f, 0.865f,  // seen 4, agreeing 3: 95220 37227 10275 1895 samples
      0.999f, 0.993f, 0.964f, 0.917f,  // seen 4, agreeing 4: 87544 25159 7002 1064 samples
  };
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
