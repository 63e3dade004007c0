#include "amhmvs_mapping/mapping/fusion.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

FusionOptions FusionOptions::paper() { return FusionOptions(); }

FusionOptions FusionOptions::reprojection() {
  FusionOptions o;
  o.max_disparity_difference = kOff;
  o.max_reprojection_error = 2.0f;
  o.max_relative_depth_difference = 0.01f;
  o.max_normal_angle_deg = 10.0f;
  o.min_consistent_views = 2;
  return o;
}

namespace {

// > 0, or +infinity (check off); NaN fails.
bool validThreshold(float value) { return value > 0; }

}  // namespace

std::string FusionOptions::validate() const {
  std::ostringstream why;
  const std::pair<const char*, float> thresholds[] = {
      {"max_disparity_difference", max_disparity_difference},
      {"max_reprojection_error", max_reprojection_error},
      {"max_relative_depth_difference", max_relative_depth_difference},
      {"max_normal_angle_deg", max_normal_angle_deg},
      {"max_cost", max_cost}};
  for (const auto& [name, value] : thresholds) {
    if (!validThreshold(value)) {
      why << name << " must be > 0 or infinity (off), got " << value;
      return why.str();
    }
  }
  if (std::isfinite(max_normal_angle_deg) && max_normal_angle_deg > 180) {
    why << "max_normal_angle_deg must be at most 180, got " << max_normal_angle_deg;
  } else if (min_consistent_views < 0 || min_consistent_views > 65535) {
    why << "min_consistent_views must be in [0, 65535], got " << min_consistent_views;
  } else if (max_sources < 0) {
    why << "max_sources must be >= 0 (0 = all), got " << max_sources;
  } else if (std::isinf(max_disparity_difference) && std::isinf(max_relative_depth_difference)) {
    why << "max_disparity_difference and max_relative_depth_difference are both off: "
           "no depth check is left";
  }
  return why.str();
}

FusionView DepthMapImages::borrow(int id, const PinholeCamera& camera) const {
  FusionView view;
  view.id = id;
  view.camera = camera;
  view.depth = depth;
  view.normal = normal;
  view.cost = cost;
  view.color = color;
  return view;
}

size_t FusionResult::pointCount() const {
  size_t n = 0;
  for (const FusedViewPoints& v : views) n += v.points.size();
  return n;
}

namespace {

std::string viewName(int id) { return "fusion: view " + std::to_string(id); }

void checkViews(const std::vector<FusionView>& views, const FusionOptions& options) {
  const std::string why = options.validate();
  if (!why.empty()) throw InputError("fusion options: " + why);
  if (views.empty()) throw InputError("fusion: no views to fuse");
  std::set<int> ids;
  for (const FusionView& v : views) {
    if (!ids.insert(v.id).second) throw InputError(viewName(v.id) + ": id given twice");
  }
  for (const FusionView& v : views) {
    const std::string name = viewName(v.id);
    const std::string camera_problem = v.camera.validate();
    if (!camera_problem.empty()) throw InputError(name + ": invalid camera: " + camera_problem);
    const int w = v.camera.width, h = v.camera.height;
    auto size = [](int width, int height) {
      return std::to_string(width) + "x" + std::to_string(height);
    };
    if (!v.depth.sameSize(w, h) || v.depth.channels != 1) {
      throw InputError(name + ": depth map is " + size(v.depth.width, v.depth.height) + " with " +
                       std::to_string(v.depth.channels) + " channel(s); its camera is " +
                       size(w, h) + " (1 channel expected)");
    }
    if (!v.normal.sameSize(w, h) || v.normal.channels != 3) {
      throw InputError(name + ": normal map is " + size(v.normal.width, v.normal.height) +
                       " with " + std::to_string(v.normal.channels) +
                       " channel(s); expected " + size(w, h) + " with 3 channels");
    }
    if (!v.cost.empty() && (!v.cost.sameSize(w, h) || v.cost.channels != 1)) {
      throw InputError(name + ": cost map size or channel count does not match the depth map");
    }
    if (!v.color.empty() && (!v.color.sameSize(w, h) ||
                             (v.color.channels != 1 && v.color.channels != 3))) {
      throw InputError(name + ": colour image is " + size(v.color.width, v.color.height) +
                       " with " + std::to_string(v.color.channels) +
                       " channel(s); expected " + size(w, h) + " with 1 or 3 channels");
    }
    std::set<int> sources;
    for (int s : v.source_ids) {
      if (s == v.id) throw InputError(name + ": lists itself as a source view");
      if (!ids.count(s)) {
        throw InputError(name + ": unknown source view id " + std::to_string(s));
      }
      if (!sources.insert(s).second) {
        throw InputError(name + ": source view id " + std::to_string(s) + " listed twice");
      }
    }
  }
}

// A view prepared for the checks: the pose in double precision and per-pixel
// validity including the cost mask.
struct PreparedView {
  const FusionView* view = nullptr;
  Eigen::Matrix3d R, Rt;  // world-to-camera rotation and its transpose
  Eigen::Vector3d t, center;
  std::vector<uint8_t> used;

  bool pixel(int x, int y, float max_cost, double* depth, Eigen::Vector3d* normal_world) const {
    const float d = view->depth.at(x, y);
    if (!(std::isfinite(d) && d > 0)) return false;
    if (!view->cost.empty() && !(view->cost.at(x, y) <= max_cost)) return false;
    const Eigen::Vector3d n(view->normal.at(x, y, 0), view->normal.at(x, y, 1),
                            view->normal.at(x, y, 2));
    const double norm = n.norm();
    if (!(std::isfinite(norm) && norm > 1e-6)) return false;
    *depth = d;
    *normal_world = Rt * (n / norm);
    return true;
  }
  Eigen::Vector3d worldPoint(int x, int y, double depth) const {
    return Rt * (view->camera.backproject(x, y, depth) - t);
  }
  Eigen::Vector3d color(int x, int y) const {
    const ImageViewU8& c = view->color;
    if (c.channels == 1) return Eigen::Vector3d::Constant(c.at(x, y));
    return {static_cast<double>(c.at(x, y, 0)), static_cast<double>(c.at(x, y, 1)),
            static_cast<double>(c.at(x, y, 2))};
  }
  bool hasColor() const { return !view->color.empty(); }
};

PreparedView prepare(const FusionView& view) {
  PreparedView p;
  p.view = &view;
  p.R = view.camera.R;
  p.Rt = view.camera.R.transpose();
  p.t = view.camera.t;
  p.center = view.camera.center();
  p.used.assign(view.depth.pixelCount(), 0);
  return p;
}

// The nearest pixel of a projection, false when outside the image.
bool nearestPixel(const PinholeCamera& camera, const Eigen::Vector2d& uv, int* x, int* y) {
  if (!uv.allFinite() || !camera.contains(uv)) return false;
  *x = static_cast<int>(std::floor(uv.x() + 0.5));
  *y = static_cast<int>(std::floor(uv.y() + 0.5));
  return *x >= 0 && *y >= 0 && *x < camera.width && *y < camera.height;
}

uint8_t toByte(double value) {
  return static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
}

struct Support {
  int source;  // index into the prepared views
  int pixel;   // linear pixel index in that view
};

class ReferenceFuser {
 public:
  ReferenceFuser(const std::vector<PreparedView>& views, const std::vector<int>& sources,
                 const FusionOptions& options)
      : views_(views),
        sources_(sources),
        options_(options),
        cos_max_angle_(std::isinf(options.max_normal_angle_deg)
                           ? -2.0
                           : std::cos(options.max_normal_angle_deg * M_PI / 180.0)) {}

  // Fuses reference pixel (x, y); appends the sources' used pixels to
  // `support` when a point is emitted.
  bool fusePixel(const PreparedView& ref, int x, int y, KeyframePoint* out,
                 std::vector<Support>* support) const {
    double depth;
    Eigen::Vector3d normal;
    if (!ref.pixel(x, y, options_.max_cost, &depth, &normal)) return false;
    const PinholeCamera& ref_camera = ref.view->camera;
    const Eigen::Vector3d X = ref.worldPoint(x, y, depth);

    Eigen::Vector3d sum_position = X, sum_normal = normal, sum_color = Eigen::Vector3d::Zero();
    int colored = 0;
    if (ref.hasColor()) {
      sum_color += ref.color(x, y);
      ++colored;
    }
    int visible = 0, consistent = 0;
    const size_t support_start = support->size();
    for (int s : sources_) {
      const PreparedView& src = views_[s];
      const PinholeCamera& src_camera = src.view->camera;
      const Eigen::Vector3d Xs = src.R * X + src.t;
      if (!(Xs.z() > 0)) continue;
      int sx, sy;
      if (!nearestPixel(src_camera, src_camera.project(Xs), &sx, &sy)) continue;
      const int src_pixel = sy * src_camera.width + sx;
      // A pixel already fused elsewhere neither supports nor counts as checked.
      if (options_.fuse_each_pixel_once && src.used[src_pixel]) continue;
      ++visible;
      double src_depth;
      Eigen::Vector3d src_normal;
      if (!src.pixel(sx, sy, options_.max_cost, &src_depth, &src_normal)) continue;
      if (normal.dot(src_normal) <= cos_max_angle_) continue;
      if (std::isfinite(options_.max_disparity_difference)) {
        // Fusibile: disparity = f_ref * baseline / depth, both depths in the source.
        const double fb = ref_camera.fx * (ref.center - src.center).norm();
        if (!(std::abs(fb / Xs.z() - fb / src_depth) < options_.max_disparity_difference)) {
          continue;
        }
      }
      const Eigen::Vector3d Xj = src.worldPoint(sx, sy, src_depth);
      if (std::isfinite(options_.max_reprojection_error) ||
          std::isfinite(options_.max_relative_depth_difference)) {
        const Eigen::Vector3d Xj_ref = ref.R * Xj + ref.t;
        if (!(Xj_ref.z() > 0)) continue;
        if (!(std::abs(Xj_ref.z() - depth) / depth < options_.max_relative_depth_difference)) {
          continue;
        }
        const Eigen::Vector2d reprojected = ref_camera.project(Xj_ref);
        if (!((reprojected - Eigen::Vector2d(x, y)).norm() < options_.max_reprojection_error)) {
          continue;
        }
      }
      sum_position += Xj;
      sum_normal += src_normal;
      if (src.hasColor()) {
        sum_color += src.color(sx, sy);
        ++colored;
      }
      ++consistent;
      support->push_back({s, src_pixel});
    }
    if (consistent < options_.min_consistent_views) {
      support->resize(support_start);
      return false;
    }
    const Eigen::Vector3d position = ref.R * (sum_position / (consistent + 1)) + ref.t;
    Eigen::Vector3d mean_normal = ref.R * sum_normal;
    // Opposite normals can only cancel with the angle check off.
    mean_normal = mean_normal.norm() > 1e-9 ? mean_normal.normalized() : ref.R * normal;
    if (!position.allFinite() || !mean_normal.allFinite()) {
      support->resize(support_start);
      return false;
    }
    out->position = position.cast<float>();
    out->normal = mean_normal.cast<float>();
    const Eigen::Vector3d color = colored ? Eigen::Vector3d(sum_color / colored)
                                          : Eigen::Vector3d::Constant(128);
    out->rgb[0] = toByte(color.x());
    out->rgb[1] = toByte(color.y());
    out->rgb[2] = toByte(color.z());
    out->consistent_views = static_cast<uint16_t>(consistent);
    out->confidence = visible ? static_cast<float>(consistent) / visible : 0.0f;
    return true;
  }

 private:
  const std::vector<PreparedView>& views_;
  const std::vector<int>& sources_;
  const FusionOptions& options_;
  double cos_max_angle_;
};

}  // namespace

FusionResult fuseDepthMaps(const std::vector<FusionView>& input, const FusionOptions& options) {
  checkViews(input, options);
  // Ascending id: the processing order that decides which view keeps a point.
  std::vector<const FusionView*> sorted;
  for (const FusionView& v : input) sorted.push_back(&v);
  std::sort(sorted.begin(), sorted.end(),
            [](const FusionView* a, const FusionView* b) { return a->id < b->id; });
  std::vector<PreparedView> views;
  std::map<int, int> index_of_id;
  for (const FusionView* v : sorted) {
    index_of_id[v->id] = static_cast<int>(views.size());
    views.push_back(prepare(*v));
  }

  FusionResult result;
  for (size_t r = 0; r < views.size(); ++r) {
    PreparedView& ref = views[r];
    const FusionView& view = *ref.view;
    std::vector<int> sources;
    for (int id : view.source_ids) {
      if (options.max_sources > 0 && static_cast<int>(sources.size()) >= options.max_sources) break;
      sources.push_back(index_of_id.at(id));
    }
    if (sources.size() < static_cast<size_t>(options.min_consistent_views)) {
      // No pixel can reach min_consistent_views (e.g. a view that only
      // supports others): it emits nothing and marks nothing.
      result.views.push_back({view.id, view.camera, {}});
      continue;
    }
    const ReferenceFuser fuser(views, sources, options);
    const int width = view.camera.width, height = view.camera.height;

    // Rows in parallel, each with its own output; concatenated in row order.
    std::vector<std::vector<KeyframePoint>> row_points(height);
    std::vector<std::vector<Support>> row_support(height);
    std::vector<size_t> row_candidates(height, 0);
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const size_t pixel = static_cast<size_t>(y) * width + x;
        if (options.fuse_each_pixel_once && ref.used[pixel]) continue;
        double depth;
        Eigen::Vector3d normal;
        if (!ref.pixel(x, y, options.max_cost, &depth, &normal)) continue;
        ++row_candidates[y];
        KeyframePoint point;
        if (!fuser.fusePixel(ref, x, y, &point, &row_support[y])) continue;
        row_points[y].push_back(point);
        if (options.fuse_each_pixel_once) row_support[y].push_back({static_cast<int>(r),
                                                                    static_cast<int>(pixel)});
      }
    }

    FusedViewPoints fused;
    fused.view_id = view.id;
    fused.camera = view.camera;
    for (int y = 0; y < height; ++y) {
      result.candidate_pixels += row_candidates[y];
      fused.points.insert(fused.points.end(), row_points[y].begin(), row_points[y].end());
      if (!options.fuse_each_pixel_once) continue;
      for (const Support& s : row_support[y]) views[s.source].used[s.pixel] = 1;
    }
    result.views.push_back(std::move(fused));
  }
  return result;
}

KeyframePoint toWorld(const KeyframePoint& point, const PinholeCamera& camera) {
  KeyframePoint out = point;
  const Eigen::Matrix3d Rt = camera.R.transpose();
  out.position = (Rt * (point.position.cast<double>() - camera.t)).cast<float>();
  out.normal = (Rt * point.normal.cast<double>()).cast<float>();
  return out;
}

PointCloud worldCloud(const FusionResult& result) {
  PointCloud cloud;
  const size_t n = result.pointCount();
  cloud.points.reserve(n);
  cloud.normals.reserve(n);
  cloud.colors.reserve(n);
  cloud.confidence.reserve(n);
  for (const FusedViewPoints& view : result.views) {
    for (const KeyframePoint& p : view.points) {
      const KeyframePoint w = toWorld(p, view.camera);
      cloud.points.push_back(w.position);
      cloud.normals.push_back(w.normal);
      cloud.colors.push_back({w.rgb[0], w.rgb[1], w.rgb[2]});
      cloud.confidence.push_back(w.confidence);
    }
  }
  return cloud;
}

}  // namespace amhmvs
