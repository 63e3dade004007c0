#include "amhmvs_mapping/mapping/fusion.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "fusion_driver.h"

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

}  // namespace

void fusion::checkViews(const std::vector<FusionView>& views, const FusionOptions& options) {
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

namespace fusion {

ViewData viewData(const FusionView& view, const float* depth, const float* normal,
                  const float* cost, const uint8_t* color, const uint8_t* used) {
  ViewData v;
  const PinholeCamera& c = view.camera;
  v.fx = c.fx;
  v.fy = c.fy;
  v.cx = c.cx;
  v.cy = c.cy;
  v.width = c.width;
  v.height = c.height;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) {
      v.R.m[3 * r + k] = c.R(r, k);
      v.Rt.m[3 * r + k] = c.R(k, r);
    }
  }
  const Eigen::Vector3d center = c.center();
  v.t = {c.t.x(), c.t.y(), c.t.z()};
  v.center = {center.x(), center.y(), center.z()};
  v.depth = depth;
  v.normal = normal;
  v.cost = view.cost.empty() ? nullptr : cost;
  v.color = view.color.empty() ? nullptr : color;
  v.color_channels = view.color.channels;
  v.used = used;
  return v;
}

Checks checks(const FusionOptions& options) {
  Checks c;
  c.max_disparity_difference = options.max_disparity_difference;
  c.max_reprojection_error = options.max_reprojection_error;
  c.max_relative_depth_difference = options.max_relative_depth_difference;
  c.cos_max_normal_angle = std::isinf(options.max_normal_angle_deg)
                               ? -2.0
                               : std::cos(options.max_normal_angle_deg * M_PI / 180.0);
  c.max_cost = options.max_cost;
  c.min_consistent_views = options.min_consistent_views;
  c.skip_used = options.fuse_each_pixel_once;
  return c;
}

KeyframePoint toKeyframePoint(const FusedPoint& p) {
  KeyframePoint k;
  k.position = Eigen::Vector3f(p.position[0], p.position[1], p.position[2]);
  k.normal = Eigen::Vector3f(p.normal[0], p.normal[1], p.normal[2]);
  k.rgb[0] = p.rgb[0];
  k.rgb[1] = p.rgb[1];
  k.rgb[2] = p.rgb[2];
  k.confidence = p.confidence;
  k.consistent_views = p.consistent_views;
  return k;
}

std::vector<FusionView> agreementViews(const FusionView& reference, const std::vector<FusionView>& views,
                                       const FusionOptions& checks) {
  std::vector<FusionView> all = views;
  for (FusionView& view : all) view.source_ids.clear();
  FusionView ref = reference;
  ref.source_ids.clear();
  for (const FusionView& view : views) ref.source_ids.push_back(view.id);
  all.push_back(std::move(ref));
  checkViews(all, checks);
  return all;
}

FusionResult runFusion(const std::vector<FusionView>& input, const FusionOptions& options,
                       ReferenceFusion* backend) {
  checkViews(input, options);
  std::vector<const FusionView*> views;
  for (const FusionView& v : input) views.push_back(&v);
  std::sort(views.begin(), views.end(),
            [](const FusionView* a, const FusionView* b) { return a->id < b->id; });
  std::map<int, int> index_of_id;
  for (size_t i = 0; i < views.size(); ++i) index_of_id[views[i]->id] = static_cast<int>(i);
  backend->begin(views, options);

  FusionResult result;
  for (size_t r = 0; r < views.size(); ++r) {
    const FusionView& view = *views[r];
    FusedViewPoints fused;
    fused.view_id = view.id;
    fused.camera = view.camera;
    std::vector<int> sources;
    for (int id : view.source_ids) {
      if (options.max_sources > 0 && static_cast<int>(sources.size()) >= options.max_sources) break;
      sources.push_back(index_of_id.at(id));
    }
    // Fewer sources than min_consistent_views: no pixel can be kept (e.g. a
    // view that only supports others); it emits nothing and marks nothing.
    if (sources.size() >= static_cast<size_t>(options.min_consistent_views)) {
      result.candidate_pixels += backend->fuseReference(static_cast<int>(r), sources, &fused.points);
    }
    result.views.push_back(std::move(fused));
  }
  return result;
}

}  // namespace fusion

namespace {

// The CPU backend: rows in parallel, each with its own output, concatenated
// in row order; marks applied when a reference is done (deterministic and
// independent of the number of threads).
class CpuReferenceFusion : public fusion::ReferenceFusion {
 public:
  void begin(const std::vector<const FusionView*>& views, const FusionOptions& options) override {
    views_ = views;
    checks_ = fusion::checks(options);
    used_.assign(views.size(), {});
    if (options.fuse_each_pixel_once) {
      for (size_t i = 0; i < views.size(); ++i) used_[i].assign(views[i]->depth.pixelCount(), 0);
    }
  }

  size_t fuseReference(int reference, const std::vector<int>& sources,
                       KeyframePoints* points) override {
    const fusion::ViewData ref = data(reference);
    std::vector<fusion::ViewData> source_data;
    for (int s : sources) source_data.push_back(data(s));
    const int count = static_cast<int>(sources.size());
    const int width = ref.width, height = ref.height;
    const bool marking = checks_.skip_used;

    std::vector<std::vector<KeyframePoint>> row_points(height);
    std::vector<std::vector<std::pair<int, int>>> row_marks(height);  // (view index, pixel)
    std::vector<size_t> row_candidates(height, 0);
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < height; ++y) {
      std::vector<int> support(count);
      for (int x = 0; x < width; ++x) {
        const int pixel = ref.pixelIndex(x, y);
        if (ref.used && ref.used[pixel]) continue;
        double depth;
        fusion::Vec3d normal;
        if (!ref.pixel(x, y, checks_.max_cost, &depth, &normal)) continue;
        ++row_candidates[y];
        fusion::FusedPoint point;
        if (!fusion::fusePixel(ref, source_data.data(), count, checks_, x, y, &point,
                               support.data())) {
          continue;
        }
        row_points[y].push_back(fusion::toKeyframePoint(point));
        if (!marking) continue;
        row_marks[y].emplace_back(reference, pixel);
        for (int k = 0; k < count; ++k) {
          if (support[k] >= 0) row_marks[y].emplace_back(sources[k], support[k]);
        }
      }
    }
    size_t candidates = 0;
    for (int y = 0; y < height; ++y) {
      candidates += row_candidates[y];
      points->insert(points->end(), row_points[y].begin(), row_points[y].end());
      for (const auto& [view, pixel] : row_marks[y]) used_[view][pixel] = 1;
    }
    return candidates;
  }

 private:
  fusion::ViewData data(int index) const {
    const FusionView& v = *views_[index];
    return fusion::viewData(v, v.depth.data, v.normal.data, v.cost.data, v.color.data,
                            used_[index].empty() ? nullptr : used_[index].data());
  }

  std::vector<const FusionView*> views_;
  fusion::Checks checks_{};
  std::vector<std::vector<uint8_t>> used_;
};

}  // namespace

FusionResult fuseDepthMaps(const std::vector<FusionView>& views, const FusionOptions& options) {
  CpuReferenceFusion cpu;
  return fusion::runFusion(views, options, &cpu);
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
