// Direct alignment of the sources before stereo (mapping/direct_alignment.h):
// the CPU driver of the per-point terms of direct_alignment_pixel.h.
#include "amhmvs_mapping/mapping/direct_alignment.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <tuple>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/median.h"
#include "amhmvs_mapping/mapping/direct_alignment_pixel.h"

namespace amhmvs {

std::string DirectAlignmentOptions::validate() const {
  std::ostringstream why;
  auto require = [&why](bool ok, const char* name, double value, const char* rule) {
    if (!ok) why << name << " must be " << rule << " (got " << value << ")\n";
  };
  require(levels >= 1 && levels <= 8, "levels", levels, "in [1, 8]");
  require(iterations >= 1, "iterations", iterations, ">= 1");
  require(std::isfinite(min_gradient) && min_gradient >= 0, "min_gradient", min_gradient, "finite and >= 0");
  require(std::isfinite(max_cost) && max_cost > 0 && max_cost <= 2, "max_cost", max_cost, "in (0, 2]");
  require(max_points >= 100, "max_points", max_points, ">= 100");
  require(min_points >= 20, "min_points", min_points, ">= 20");
  require(std::isfinite(huber_grey) && huber_grey > 0, "huber_grey", huber_grey, "finite and > 0");
  require(std::isfinite(max_correction_m) && max_correction_m > 0, "max_correction_m", max_correction_m,
          "finite and > 0");
  require(std::isfinite(max_correction_deg) && max_correction_deg > 0 && max_correction_deg <= 180,
          "max_correction_deg", max_correction_deg, "in (0, 180]");
  return why.str();
}

const std::vector<DirectAlignmentOptionInfo>& directAlignmentOptionTable() {
  using O = DirectAlignmentOptions;
  static const std::vector<DirectAlignmentOptionInfo> table = {
      switchField<O>("enabled", &O::enabled,
                     "align each keyframe's sources to it photometrically before stereo (sources with a depth map; "
                     "depth, clouds and map stay in the tracker's frame)"),
      switchField<O>("across_epipolar_only", &O::across_epipolar_only,
                     "only the motion across epipolar lines is aligned (for a tracker whose baselines are off: the "
                     "sources' depth then errs along the lines); off: all of it (an accurate tracker)"),
      numberField("levels", &O::levels, "image pyramid levels, coarse to fine"),
      numberField("iterations", &O::iterations, "Levenberg-Marquardt steps per level, at most"),
      numberField("min_gradient", &O::min_gradient,
                  "a source pixel is used when its grey-level gradient (per pixel of its level) is at least this"),
      numberField("max_cost", &O::max_cost,
                  "...and its depth's matching cost (0..2) at most this"),
      numberField("max_points", &O::max_points, "points per source and level, at most (evenly thinned)"),
      numberField("min_points", &O::min_points, "fewer points at the finest level: the tracker's pose stays"),
      numberField("huber_grey", &O::huber_grey, "residuals beyond this many grey levels weigh less (Huber)"),
      numberField("max_correction_m", &O::max_correction_m,
                  "a larger shift of a source's centre is rejected (the tracker's pose stays), m"),
      numberField("max_correction_deg", &O::max_correction_deg,
                  "a larger rotation of a source is rejected (the tracker's pose stays), deg"),
  };
  return table;
}

const char* sourceAlignmentOutcomeName(SourceAlignmentOutcome outcome) {
  switch (outcome) {
    case SourceAlignmentOutcome::kAligned: return "aligned";
    case SourceAlignmentOutcome::kNoDepth: return "no_depth";
    case SourceAlignmentOutcome::kTooFewPoints: return "too_few_points";
    case SourceAlignmentOutcome::kNotBetter: return "not_better";
    case SourceAlignmentOutcome::kRejected: return "rejected";
  }
  return "unknown";
}

int DirectAlignmentResult::alignedCount() const {
  return static_cast<int>(std::count_if(sources.begin(), sources.end(), [](const SourceAlignment& s) {
    return s.outcome == SourceAlignmentOutcome::kAligned;
  }));
}

namespace {

using Vector8 = Eigen::Matrix<double, mvs::kAlignmentParameters, 1>;
using Matrix8 = Eigen::Matrix<double, mvs::kAlignmentParameters, mvs::kAlignmentParameters>;

// Grey levels as floats, each level the 2x2 mean of the one below.
std::vector<ImageF> pyramid(const ImageViewU8& image, int levels) {
  std::vector<ImageF> out(1, ImageF(image.width, image.height, 1));
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) out[0].at(x, y) = image.at(x, y);
  for (int level = 1; level < levels; ++level) {
    const ImageF& below = out.back();
    if (below.width < 16 || below.height < 16) break;
    ImageF next(below.width / 2, below.height / 2, 1);
    for (int y = 0; y < next.height; ++y)
      for (int x = 0; x < next.width; ++x)
        next.at(x, y) = 0.25f * (below.at(2 * x, 2 * y) + below.at(2 * x + 1, 2 * y) + below.at(2 * x, 2 * y + 1) +
                                 below.at(2 * x + 1, 2 * y + 1));
    out.push_back(std::move(next));
  }
  return out;
}

// Bilinear, clamped to the image.
struct FloatSampler {
  const ImageF* image;
  float operator()(float x, float y) const {
    x = std::min(std::max(x, 0.0f), image->width - 1.001f);
    y = std::min(std::max(y, 0.0f), image->height - 1.001f);
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const float fx = x - x0, fy = y - y0;
    const float top = image->at(x0, y0) * (1 - fx) + image->at(x0 + 1, y0) * fx;
    const float bottom = image->at(x0, y0 + 1) * (1 - fx) + image->at(x0 + 1, y0 + 1) * fx;
    return top * (1 - fy) + bottom * fy;
  }
};

mvs::AlignmentIntrinsics levelIntrinsics(const PinholeCamera& camera, const ImageF& level_image, int level) {
  const float scale = 1.0f / static_cast<float>(1 << level);
  return {static_cast<float>(camera.fx * scale), static_cast<float>(camera.fy * scale),
          static_cast<float>((camera.cx + 0.5) * scale - 0.5), static_cast<float>((camera.cy + 0.5) * scale - 0.5),
          level_image.width, level_image.height};
}

// The source's surface points that fall on textured pixels of one level,
// with their grey level there.
std::vector<mvs::AlignmentPoint> selectPoints(const ImageF& level_image, int level,
                                              const std::vector<Eigen::Vector3f>& surface,
                                              const PinholeCamera& camera, const DirectAlignmentOptions& options) {
  std::vector<mvs::AlignmentPoint> points;
  const float min_gradient_squared = static_cast<float>(options.min_gradient * options.min_gradient);
  const float scale = 1.0f / static_cast<float>(1 << level);
  const FloatSampler sample{&level_image};
  for (const Eigen::Vector3f& p : surface) {
    if (!(p.z() > 0)) continue;
    // The level's pixel coordinates (levelIntrinsics' mapping, in double: the
    // measured results were made with this rounding).
    const float x = static_cast<float>((camera.fx * p.x() / p.z() + camera.cx + 0.5) * scale - 0.5);
    const float y = static_cast<float>((camera.fy * p.y() / p.z() + camera.cy + 0.5) * scale - 0.5);
    if (!(x >= 1 && y >= 1 && x <= level_image.width - 2 && y <= level_image.height - 2)) continue;
    const float gx = 0.5f * (sample(x + 1, y) - sample(x - 1, y));
    const float gy = 0.5f * (sample(x, y + 1) - sample(x, y - 1));
    if (gx * gx + gy * gy < min_gradient_squared) continue;
    points.push_back({mvs::make_vec3(p.x(), p.y(), p.z()), sample(x, y)});
  }
  if (static_cast<int>(points.size()) > options.max_points) {
    std::vector<mvs::AlignmentPoint> thinned;
    thinned.reserve(options.max_points);
    const double step = static_cast<double>(points.size()) / options.max_points;
    for (int i = 0; i < options.max_points; ++i) thinned.push_back(points[static_cast<size_t>(i * step)]);
    points.swap(thinned);
  }
  return points;
}

struct Relative {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double log_gain = 0, bias = 0;
  bool across_epipolar = false;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  // the reference's at the level (for the epipole)
};

mvs::AlignmentState toState(const Relative& relative) {
  mvs::AlignmentState state;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) state.rotation[3 * r + c] = static_cast<float>(relative.R(r, c));
  state.translation = mvs::make_vec3(static_cast<float>(relative.t.x()), static_cast<float>(relative.t.y()),
                                     static_cast<float>(relative.t.z()));
  state.log_gain = static_cast<float>(relative.log_gain);
  state.bias = static_cast<float>(relative.bias);
  state.across_epipolar = relative.across_epipolar;
  const Eigen::Vector3d epipole = relative.K * relative.t;
  state.epipole = mvs::make_vec3(static_cast<float>(epipole.x()), static_cast<float>(epipole.y()),
                                 static_cast<float>(epipole.z()));
  return state;
}

// Left increment: X' = exp(w) X + v, then the brightness.
Relative applied(const Relative& relative, const Vector8& step) {
  Relative out = relative;
  const Eigen::Vector3d w = step.segment<3>(3);
  const Eigen::Matrix3d turn =
      w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
  out.R = turn * relative.R;
  out.t = turn * relative.t + step.segment<3>(0);
  out.log_gain += step(6);
  out.bias += step(7);
  return out;
}

// Robust cost of the points at `relative` (a point out of view costs as a
// residual of three Huber widths), and the normal equations when asked.
struct Evaluation {
  double cost = 0;
  double squares = 0;  // of the in-view residuals
  int in_view = 0;
  Matrix8 H = Matrix8::Zero();
  Vector8 g = Vector8::Zero();
};

Evaluation evaluate(const std::vector<mvs::AlignmentPoint>& points, const Relative& relative,
                    const mvs::AlignmentIntrinsics& intrinsics, const ImageF& reference, float huber,
                    bool normal_equations) {
  Evaluation out;
  const mvs::AlignmentState state = toState(relative);
  const FloatSampler sample{&reference};
  // Across epipolar lines a term weighs c^2, 1/2 on average over directions.
  const double out_of_view = mvs::huberCost(3 * huber, huber) * (relative.across_epipolar ? 0.5 : 1.0);
  for (const mvs::AlignmentPoint& point : points) {
    mvs::AlignmentTerm term;
    if (!mvs::alignmentTerm(point, state, intrinsics, sample, &term)) {
      out.cost += out_of_view;
      continue;
    }
    ++out.in_view;
    out.cost += term.weight * mvs::huberCost(term.residual, huber);
    out.squares += static_cast<double>(term.residual) * term.residual;
    if (!normal_equations) continue;
    const double weight = term.weight * mvs::huberWeight(term.residual, huber);
    const Eigen::Map<const Eigen::Matrix<float, mvs::kAlignmentParameters, 1>> J(term.jacobian);
    const Vector8 Jd = J.cast<double>();
    out.H.selfadjointView<Eigen::Upper>().rankUpdate(Jd, weight);
    out.g += weight * term.residual * Jd;
  }
  out.H = out.H.selfadjointView<Eigen::Upper>();
  return out;
}

// Levenberg-Marquardt on one level.
Relative alignLevel(const std::vector<mvs::AlignmentPoint>& points, Relative relative,
                    const mvs::AlignmentIntrinsics& intrinsics, const ImageF& reference, float huber, int iterations) {
  Evaluation current = evaluate(points, relative, intrinsics, reference, huber, true);
  double lambda = 1e-3;
  for (int i = 0; i < iterations && current.in_view >= mvs::kAlignmentParameters; ++i) {
    Matrix8 damped = current.H;
    // Pose directions the points do not observe (along epipolar lines) get
    // a floor, so that a tiny gradient there takes no large step; the
    // brightness is always observed.
    Vector8 damping = lambda * damped.diagonal();
    const double floor = 1e-4 * damped.diagonal().head<6>().maxCoeff();
    damping.head<6>() = damping.head<6>().cwiseMax(floor);
    damped.diagonal() += damping;
    const Vector8 step = damped.ldlt().solve(-current.g);
    if (!step.allFinite()) break;
    const Relative candidate = applied(relative, step);
    const Evaluation next = evaluate(points, candidate, intrinsics, reference, huber, true);
    if (next.cost < current.cost) {
      relative = candidate;
      const bool converged = next.cost > current.cost * (1 - 1e-4);
      current = next;
      lambda = std::max(lambda * 0.3, 1e-7);
      if (converged) break;
    } else {
      lambda *= 8;
      if (lambda > 1e5) break;
    }
  }
  return relative;
}

// The brightness offset that centres the residuals at the tracker's pose.
double medianOffset(const std::vector<mvs::AlignmentPoint>& points, const Relative& relative,
                    const mvs::AlignmentIntrinsics& intrinsics, const ImageF& reference) {
  std::vector<float> differences;
  const mvs::AlignmentState state = toState(relative);
  const FloatSampler sample{&reference};
  for (const mvs::AlignmentPoint& point : points) {
    mvs::AlignmentTerm term;
    if (mvs::alignmentTerm(point, state, intrinsics, sample, &term)) differences.push_back(term.residual);
  }
  if (differences.empty()) return 0;
  std::nth_element(differences.begin(), differences.begin() + differences.size() / 2, differences.end());
  return differences[differences.size() / 2];
}

// Median |shift| of the points' reference pixels from `from` to `to`, across
// and along `from`'s epipolar lines.
std::pair<double, double> medianShifts(const std::vector<mvs::AlignmentPoint>& points, const Relative& from,
                                       const Relative& to, const Eigen::Matrix3d& K) {
  std::vector<double> across, along;
  const Eigen::Vector3d epipole = K * from.t;
  for (const mvs::AlignmentPoint& point : points) {
    const Eigen::Vector3d p(point.point.x, point.point.y, point.point.z);
    const Eigen::Vector3d a = K * (from.R * p + from.t), b = K * (to.R * p + to.t);
    if (!(a.z() > 0) || !(b.z() > 0)) continue;
    const Eigen::Vector2d ua = a.hnormalized(), ub = b.hnormalized();
    const Eigen::Vector3d line = Eigen::Vector3d(ua.x(), ua.y(), 1).cross(epipole);
    const double norm = line.head<2>().norm();
    if (!(norm > 0)) continue;
    const Eigen::Vector2d n = line.head<2>() / norm, d = ub - ua;
    across.push_back(std::abs(d.dot(n)));
    along.push_back((d - d.dot(n) * n).norm());
  }
  if (across.empty()) return {0, 0};
  return {medianOf(across), medianOf(along)};
}

SourceAlignment alignSource(const PinholeCamera& reference_camera, const std::vector<ImageF>& reference_pyramid,
                            const ImageViewU8& source_image, const std::vector<Eigen::Vector3f>& surface,
                            PinholeCamera* source_camera,
                            const DirectAlignmentOptions& options) {
  SourceAlignment out;
  const std::vector<ImageF> source_pyramid = pyramid(source_image, static_cast<int>(reference_pyramid.size()));
  const int levels = static_cast<int>(std::min(source_pyramid.size(), reference_pyramid.size()));
  Relative tracker;
  tracker.R = reference_camera.R * source_camera->R.transpose();
  tracker.t = reference_camera.t - tracker.R * source_camera->t;
  const float huber = static_cast<float>(options.huber_grey);
  tracker.across_epipolar = options.across_epipolar_only;
  Relative relative = tracker;
  std::vector<mvs::AlignmentPoint> finest;
  for (int level = levels - 1; level >= 0; --level) {
    std::vector<mvs::AlignmentPoint> points =
        selectPoints(source_pyramid[level], level, surface, *source_camera, options);
    const mvs::AlignmentIntrinsics intrinsics = levelIntrinsics(reference_camera, reference_pyramid[level], level);
    relative.K << intrinsics.fx, 0, intrinsics.cx, 0, intrinsics.fy, intrinsics.cy, 0, 0, 1;
    if (level == levels - 1) relative.bias = medianOffset(points, relative, intrinsics, reference_pyramid[level]);
    if (static_cast<int>(points.size()) >= mvs::kAlignmentParameters)
      relative = alignLevel(points, relative, intrinsics, reference_pyramid[level], huber, options.iterations);
    if (level == 0) finest.swap(points);
  }
  const mvs::AlignmentIntrinsics intrinsics = levelIntrinsics(reference_camera, reference_pyramid[0], 0);
  tracker.K = relative.K;
  const Evaluation before = evaluate(finest, tracker, intrinsics, reference_pyramid[0], huber, false);
  const Evaluation after = evaluate(finest, relative, intrinsics, reference_pyramid[0], huber, false);
  out.points = before.in_view;
  out.rms_before_grey = before.in_view > 0 ? std::sqrt(before.squares / before.in_view) : 0;
  if (before.in_view < options.min_points) {
    out.outcome = SourceAlignmentOutcome::kTooFewPoints;
    return out;
  }
  out.rms_after_grey = after.in_view > 0 ? std::sqrt(after.squares / after.in_view) : 0;
  out.gain = std::exp(relative.log_gain);
  out.bias = relative.bias;
  // The aligned source camera: x_s = R^T (x_r - t), x_r = R_ref x_w + t_ref.
  PinholeCamera aligned = *source_camera;
  aligned.R = relative.R.transpose() * reference_camera.R;
  aligned.t = relative.R.transpose() * (reference_camera.t - relative.t);
  out.correction_m = (aligned.center() - source_camera->center()).norm();
  out.correction_deg = rotationAngleDeg(aligned.R * source_camera->R.transpose());
  std::tie(out.shift_across_px, out.shift_along_px) = medianShifts(finest, tracker, relative, relative.K);
  // Compared with the tracker's pose at its best brightness (the offset alone
  // must not count as an improvement).
  Relative tracker_lit = tracker;
  tracker_lit.log_gain = relative.log_gain;
  tracker_lit.bias = relative.bias;
  const Evaluation baseline = evaluate(finest, tracker_lit, intrinsics, reference_pyramid[0], huber, false);
  if (!(after.cost < baseline.cost) || !aligned.R.allFinite() || !aligned.t.allFinite()) {
    out.outcome = SourceAlignmentOutcome::kNotBetter;
  } else if (out.correction_m > options.max_correction_m || out.correction_deg > options.max_correction_deg) {
    out.outcome = SourceAlignmentOutcome::kRejected;
  } else {
    out.outcome = SourceAlignmentOutcome::kAligned;
    *source_camera = aligned;
  }
  return out;
}

}  // namespace

std::vector<Eigen::Vector3f> confidentDepthPoints(const DepthMap& depth, const PinholeCamera& camera,
                                                  double max_cost) {
  std::vector<Eigen::Vector3f> points;
  if (!depth.depth.sameSize(camera.width, camera.height) || !depth.cost.sameSize(camera.width, camera.height))
    return points;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const float z = depth.depth.at(x, y);
      if (z > 0 && std::isfinite(z) && depth.cost.at(x, y) <= max_cost)
        points.push_back(camera.backproject(x, y, z).cast<float>());
    }
  }
  return points;
}

DirectAlignmentResult alignSourcesDirectly(DepthProblem* problem,
                                           const std::vector<std::vector<Eigen::Vector3f>>& source_surfaces,
                                           const DirectAlignmentOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const std::string invalid_options = options.validate();
  if (!invalid_options.empty()) throw InputError("direct alignment options:\n" + invalid_options);
  const std::string invalid_problem = problem->validate();
  if (!invalid_problem.empty()) throw InputError(invalid_problem);
  if (source_surfaces.size() != problem->source_cameras.size())
    throw InputError("direct alignment: " + std::to_string(source_surfaces.size()) + " source surfaces for " +
                     std::to_string(problem->source_cameras.size()) + " sources");
  DirectAlignmentResult result;
  result.ran = true;
  result.sources.resize(problem->source_cameras.size());
  const std::vector<ImageF> reference_pyramid = pyramid(problem->reference_image, options.levels);
  for (size_t s = 0; s < problem->source_cameras.size(); ++s) {
    if (source_surfaces[s].empty()) continue;  // kNoDepth
    result.sources[s] = alignSource(problem->reference_camera, reference_pyramid, problem->source_images[s],
                                    source_surfaces[s], &problem->source_cameras[s], options);
  }
  result.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace amhmvs
