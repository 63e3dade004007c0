#include "amhmvs_mapping/eval/depth_metrics.h"

#include <algorithm>
#include <cmath>
#include <vector>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/text.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/pfm.h"

namespace amhmvs {

void AccuracyCounts::add(double estimate, double truth) {
  ++total;
  if (!std::isfinite(estimate)) return;
  const double error = std::abs(estimate - truth) / truth;
  for (size_t i = 0; i < thresholds.size(); ++i) within[i] += error < thresholds[i];
}

void AccuracyCounts::merge(const AccuracyCounts& other) {
  total += other.total;
  for (size_t i = 0; i < within.size(); ++i) within[i] += other.within[i];
}

std::string AccuracyCounts::percentages() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2);
  for (size_t i = 0; i < thresholds.size(); ++i) out << (i ? " / " : "") << 100.0 * fraction(i);
  return out.str();
}

AccuracyCounts denseDepthAccuracy(const ImageF& depth, const ImageF& truth,
                                  const ImageU8* valid_mask) {
  if (!depth.sameSize(truth.width, truth.height)) {
    throw InputError("depth map and ground truth differ in size");
  }
  AccuracyCounts counts;
  for (int y = 0; y < truth.height; ++y) {
    for (int x = 0; x < truth.width; ++x) {
      const float t = truth.at(x, y);
      if (!(std::isfinite(t) && t > 0)) continue;
      if (valid_mask && valid_mask->at(x, y) == 0) continue;
      counts.add(depth.at(x, y), t);
    }
  }
  return counts;
}

DepthComparison compareDepth(const ImageF& estimate, const ImageF& truth, const ImageU8* mask) {
  if (!estimate.sameSize(truth.width, truth.height) || (mask && !mask->sameSize(truth.width, truth.height))) {
    throw InputError("depth map, ground truth and mask differ in size");
  }
  DepthComparison comparison;
  for (size_t i = 0; i < truth.data.size(); ++i) {
    const float t = truth.data[i], d = estimate.data[i];
    if (!(std::isfinite(t) && t > 0) || (mask && mask->data[i] == 0)) continue;
    ++comparison.truth_pixels;
    if (std::isfinite(d) && d > 0) comparison.accuracy.add(d, t);
  }
  return comparison;
}

namespace {

// calib.txt: "key=value" lines; values may carry stray spaces; K as
// "[f 0 cx; 0 f cy; 0 0 1]".
std::map<std::string, std::string> readKeyValues(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open");
  std::map<std::string, std::string> values;
  std::string line;
  while (std::getline(in, line)) {
    const size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    values[trimmed(line.substr(0, eq))] = trimmed(line.substr(eq + 1));
  }
  return values;
}

double number(const std::map<std::string, std::string>& values, const std::string& key,
              const std::string& path) {
  const auto it = values.find(key);
  double v;
  if (it == values.end() || !(std::istringstream(it->second) >> v) || !std::isfinite(v)) {
    throw InputError(path + ": missing or invalid '" + key + "'");
  }
  return v;
}

}  // namespace

MiddleburyGroundTruth readMiddleburyGroundTruth(const std::string& dir) {
  const std::string calib_path = dir + "/calib.txt";
  const auto calib = readKeyValues(calib_path);
  const auto cam0 = calib.find("cam0");
  double f = 0;
  if (cam0 == calib.end() || !(std::istringstream(cam0->second.substr(cam0->second.find('[') + 1)) >> f) ||
      !(f > 0)) {
    throw InputError(calib_path + ": missing or invalid 'cam0'");
  }
  const double doffs = number(calib, "doffs", calib_path);
  const double baseline_m = number(calib, "baseline", calib_path) / 1000.0;
  const ImageF disparity = readPfm(dir + "/disp0GT.pfm");

  MiddleburyGroundTruth gt;
  gt.depth = ImageF(disparity.width, disparity.height);
  for (size_t i = 0; i < disparity.data.size(); ++i) {
    const float d = disparity.data[i];
    gt.depth.data[i] = std::isfinite(d) ? static_cast<float>(baseline_m * f / (d + doffs))
                                        : std::numeric_limits<float>::quiet_NaN();
  }
  std::string mask_path;
  for (const char* ext : {"png", "pgm", "pnm"}) {
    const std::string candidate = dir + "/mask0nocc." + ext;
    if (std::ifstream(candidate)) {
      mask_path = candidate;
      break;
    }
  }
  if (mask_path.empty()) throw InputError(dir + ": no mask0nocc.png or mask0nocc.pgm");
  gt.nonoccluded = toGray(readImage(mask_path));
  if (!gt.nonoccluded.sameSize(gt.depth.width, gt.depth.height)) {
    throw InputError(mask_path + ": size differs from disp0GT.pfm");
  }
  for (uint8_t& m : gt.nonoccluded.data) m = m == 255 ? 255 : 0;
  return gt;
}

std::vector<SparsePoint> readSparsePoints(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open");
  std::vector<SparsePoint> points;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    SparsePoint p;
    int count = 0;
    if (!(fields >> p.position.x() >> p.position.y() >> p.position.z() >> count) || count < 0 ||
        !p.position.allFinite()) {
      throw InputError(path + ": line " + std::to_string(line_number) + ": expected 'X Y Z N ids'");
    }
    p.views.resize(count);
    for (int& v : p.views) {
      if (!(fields >> v)) {
        throw InputError(path + ": line " + std::to_string(line_number) + ": fewer view ids than N");
      }
    }
    points.push_back(std::move(p));
  }
  return points;
}

AccuracyCounts sparsePointAccuracy(const ImageF& depth, const PinholeCamera& camera, int view_id,
                                   const std::vector<SparsePoint>& points) {
  AccuracyCounts counts;
  for (const SparsePoint& p : points) {
    bool observed = false;
    for (int v : p.views) observed |= v == view_id;
    if (!observed) continue;
    const Eigen::Vector3d x = camera.toCamera(p.position);
    if (x.z() <= 0) continue;
    const Eigen::Vector2d uv = camera.project(x);
    const long u = std::lround(uv.x()), v = std::lround(uv.y());
    if (u < 0 || v < 0 || u >= depth.width || v >= depth.height) continue;
    counts.add(depth.at(static_cast<int>(u), static_cast<int>(v)), x.z());
  }
  return counts;
}

}  // namespace amhmvs
