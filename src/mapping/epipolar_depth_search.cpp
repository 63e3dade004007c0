#include "amhmvs_mapping/mapping/epipolar_depth_search.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

// Samples along a line before counting its length in pixels.
constexpr int kLengthProbes = 256;
// A runner-up this close (pixels) to the best position is the same match.
constexpr double kSamePeakPixels = 2.0;

double bilinear(const ImageU8& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  const auto at = [&](int u, int v) { return static_cast<double>(image.at(u, v)); };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) +
         ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
}

// Mean-free, unit-norm patch of `image` at integer centre (x, y); false when
// its standard deviation is below min_texture.
bool normalisedPatch(const ImageU8& image, double x, double y, int radius, double min_texture,
                     std::vector<double>* patch) {
  patch->clear();
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) patch->push_back(bilinear(image, x + dx, y + dy));
  double mean = 0;
  for (double v : *patch) mean += v;
  mean /= patch->size();
  double norm = 0;
  for (double& v : *patch) {
    v -= mean;
    norm += v * v;
  }
  if (std::sqrt(norm / patch->size()) < min_texture) return false;
  for (double& v : *patch) v /= std::sqrt(norm);
  return true;
}

bool insideWithMargin(const ImageU8& image, const Eigen::Vector2d& pixel, int margin) {
  return pixel.x() >= margin && pixel.y() >= margin && pixel.x() < image.width - 1 - margin &&
         pixel.y() < image.height - 1 - margin;
}

// The epipolar line of one target pixel: source pixel of inverse depth w is
// the dehomogenised a + w b (X_src = d R r + t, divided by d = 1 / w).
struct EpipolarLine {
  Eigen::Vector3d a, b;
  bool pixelAt(double w, Eigen::Vector2d* pixel) const {
    const Eigen::Vector3d h = a + w * b;
    if (h.z() <= 1e-12) return false;
    *pixel = h.head<2>() / h.z();
    return true;
  }
};

struct Sample {
  Eigen::Vector2d pixel;
  double w = 0, correlation = -1;
};

// The inverse depths (within (0, w_max]) whose source pixels lie inside the
// source image, and the pixel length of that part of the line.
struct VisibleSpan {
  double w_low = 0, w_high = 0, length = 0;
};

VisibleSpan visibleSpan(const EpipolarLine& line, double w_max, const ImageU8& source, int margin) {
  VisibleSpan span;
  Eigen::Vector2d previous, pixel;
  bool have_previous = false;
  int first = -1, last = -1;
  for (int k = 1; k <= kLengthProbes; ++k) {
    const bool visible = line.pixelAt(w_max * k / kLengthProbes, &pixel) && insideWithMargin(source, pixel, margin);
    if (visible) {
      if (first < 0) first = k;
      last = k;
      if (have_previous) span.length += (pixel - previous).norm();
    }
    have_previous = visible;
    previous = pixel;
  }
  if (first < 0) return span;
  // One probe more on each side: the line may enter the image between probes.
  span.w_low = w_max * std::max(first - 1, 0) / kLengthProbes;
  span.w_high = w_max * std::min(last + 1, kLengthProbes) / kLengthProbes;
  span.length += 2 * std::max(source.width, source.height) / static_cast<double>(kLengthProbes);
  return span;
}

// Inverse depth of the unique best match, or 0 when there is none. Samples
// about every half pixel of the visible part of the line; the best local
// maximum of the correlation must beat every other one by uniqueness_margin.
double bestInverseDepth(const std::vector<double>& target_patch, const EpipolarLine& line, double w_max,
                        const ImageU8& source, const EpipolarSearchOptions& options) {
  const int r = options.patch_radius;
  const VisibleSpan span = visibleSpan(line, w_max, source, r);
  if (span.length < 1) return 0;
  const int steps = std::max(16, std::min(options.max_steps, static_cast<int>(2 * span.length)));
  std::vector<Sample> samples;
  std::vector<double> source_patch;
  for (int k = 0; k <= steps; ++k) {
    Sample sample;
    sample.w = span.w_low + (span.w_high - span.w_low) * k / steps;
    if (sample.w <= 0 || !line.pixelAt(sample.w, &sample.pixel) || !insideWithMargin(source, sample.pixel, r)) continue;
    sample.correlation = -1;  // a flat source patch matches nothing
    if (normalisedPatch(source, sample.pixel.x(), sample.pixel.y(), r, 1e-6, &source_patch)) {
      sample.correlation = 0;
      for (size_t i = 0; i < source_patch.size(); ++i) sample.correlation += target_patch[i] * source_patch[i];
    }
    samples.push_back(sample);
  }
  std::vector<Sample> peaks;  // local maxima along the line
  for (size_t i = 0; i < samples.size(); ++i) {
    const double c = samples[i].correlation;
    if ((i == 0 || c >= samples[i - 1].correlation) && (i + 1 == samples.size() || c >= samples[i + 1].correlation))
      peaks.push_back(samples[i]);
  }
  if (peaks.empty()) return 0;
  const Sample best = *std::max_element(peaks.begin(), peaks.end(), [](const Sample& x, const Sample& y) {
    return x.correlation < y.correlation;
  });
  if (best.correlation < options.min_correlation) return 0;
  for (const Sample& other : peaks) {
    if ((other.pixel - best.pixel).norm() > kSamePeakPixels &&
        other.correlation > best.correlation - options.uniqueness_margin)
      return 0;
  }
  return best.w;
}

void requireImageOf(const PinholeCamera& camera, const ImageU8& image, const char* name) {
  if (image.channels != 1 || !image.sameSize(camera.width, camera.height) || image.data.size() != image.pixelCount()) {
    std::ostringstream why;
    why << "epipolar depth search: " << name << " image is " << image.width << "x" << image.height << "x"
        << image.channels << ", its camera " << camera.width << "x" << camera.height << "x1";
    throw InputError(why.str());
  }
}

}  // namespace

std::string EpipolarSearchOptions::validate() const {
  std::ostringstream why;
  if (grid_size < 1 || grid_size > 1000) why << "grid_size must be in [1, 1000] (got " << grid_size << ")\n";
  if (patch_radius < 1 || patch_radius > 20) why << "patch_radius must be in [1, 20] (got " << patch_radius << ")\n";
  if (!(std::isfinite(min_texture) && min_texture >= 0)) why << "min_texture must be >= 0\n";
  if (!(std::isfinite(min_depth) && min_depth > 0)) why << "min_depth must be positive and finite\n";
  if (max_steps < 16) why << "max_steps must be >= 16 (got " << max_steps << ")\n";
  if (!(min_correlation > -1 && min_correlation <= 1)) why << "min_correlation must be in (-1, 1]\n";
  if (!(uniqueness_margin >= 0 && uniqueness_margin < 2)) why << "uniqueness_margin must be in [0, 2)\n";
  return why.str();
}

std::vector<double> matchDepthsAlongEpipolarLines(const PinholeCamera& target_camera, const ImageU8& target_image,
                                                  const PinholeCamera& source_camera, const ImageU8& source_image,
                                                  const EpipolarSearchOptions& options) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw InputError("epipolar depth search options: " + problems);
  requireImageOf(target_camera, target_image, "target");
  requireImageOf(source_camera, source_image, "source");
  const RelativePose to_source = relativePose(target_camera, source_camera);
  const Eigen::Matrix3d K_source = source_camera.K();
  const double w_max = 1.0 / options.min_depth;
  const int r = options.patch_radius;
  std::vector<double> depths;
  std::vector<double> target_patch;
  const int n = options.grid_size;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      // Integer pixel centres spread over the image, patches inside it.
      const int x = r + static_cast<int>((i + 0.5) * (target_image.width - 2 * r - 1) / n);
      const int y = r + static_cast<int>((j + 0.5) * (target_image.height - 2 * r - 1) / n);
      if (!normalisedPatch(target_image, x, y, r, options.min_texture, &target_patch)) continue;
      const Eigen::Vector3d ray = target_camera.backproject(x, y, 1.0);
      const EpipolarLine line{K_source * (to_source.R * ray), K_source * to_source.t};
      const double w = bestInverseDepth(target_patch, line, w_max, source_image, options);
      if (w > 0) depths.push_back(1.0 / w);
    }
  }
  return depths;
}

}  // namespace amhmvs
