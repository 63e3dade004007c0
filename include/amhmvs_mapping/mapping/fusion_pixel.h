// The fusion's per-pixel consistency check (paper section 3.3; definitions in
// fusion.h), written once for the CPU loop (fusion.cpp) and the CUDA kernel
// (cuda/cuda_fusion.cu). Double precision on both, as the checks compare
// small differences of depths and pixel positions.
#pragma once

#include <cmath>
#include <cstdint>

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {
namespace fusion {

struct Vec3d {
  double x, y, z;
};

AMHMVS_HD Vec3d operator+(Vec3d a, Vec3d b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
AMHMVS_HD Vec3d operator-(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
AMHMVS_HD Vec3d operator*(double s, Vec3d a) { return {s * a.x, s * a.y, s * a.z}; }
AMHMVS_HD Vec3d operator/(Vec3d a, double s) { return {a.x / s, a.y / s, a.z / s}; }
AMHMVS_HD double dot(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
AMHMVS_HD double norm(Vec3d a) { return sqrt(dot(a, a)); }
AMHMVS_HD bool finite(double v) { return mvs::isfinite_hd(v); }
AMHMVS_HD bool finite(Vec3d a) { return finite(a.x) && finite(a.y) && finite(a.z); }

// Row-major 3x3.
struct Mat3d {
  double m[9];
};
AMHMVS_HD Vec3d mul(const Mat3d& a, Vec3d v) {
  return {a.m[0] * v.x + a.m[1] * v.y + a.m[2] * v.z, a.m[3] * v.x + a.m[4] * v.y + a.m[5] * v.z,
          a.m[6] * v.x + a.m[7] * v.y + a.m[8] * v.z};
}

// One view as the check reads it: camera and borrowed maps (host or device
// memory, interleaved like ImageView).
struct ViewData {
  double fx, fy, cx, cy;
  int width, height;
  Mat3d R, Rt;       // world-to-camera rotation and its transpose
  Vec3d t, center;   // X_cam = R X + t; centre in the world
  const float* depth;     // 1 channel
  const float* normal;    // 3 channels, camera frame
  const float* cost;      // 1 channel or null
  const uint8_t* color;   // color_channels (1 or 3) or null
  int color_channels;
  const uint8_t* used;    // "fused before" marks or null (none)

  AMHMVS_HD int pixelIndex(int x, int y) const { return y * width + x; }

  // Depth and world-frame unit normal of pixel (x, y); false where the pixel
  // has no usable estimate (non-finite or non-positive depth, cost above
  // max_cost, normal of no length).
  AMHMVS_HD bool pixel(int x, int y, float max_cost, double* d, Vec3d* normal_world) const {
    const int i = pixelIndex(x, y);
    const float depth_value = depth[i];
    if (!(finite(depth_value) && depth_value > 0)) return false;
    if (cost && !(cost[i] <= max_cost)) return false;
    const Vec3d n{normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]};
    const double length = norm(n);
    if (!(finite(length) && length > 1e-6)) return false;
    *d = depth_value;
    *normal_world = mul(Rt, n / length);
    return true;
  }
  AMHMVS_HD Vec3d worldPoint(int x, int y, double d) const {
    const Vec3d camera_point{(x - cx) / fx * d, (y - cy) / fy * d, d};
    return mul(Rt, camera_point - t);
  }
  AMHMVS_HD Vec3d colorAt(int x, int y) const { return colorOfPixel(pixelIndex(x, y)); }
  AMHMVS_HD Vec3d colorOfPixel(int i) const {
    if (color_channels == 1) return {double(color[i]), double(color[i]), double(color[i])};
    return {double(color[3 * i]), double(color[3 * i + 1]), double(color[3 * i + 2])};
  }
  // The nearest pixel of camera point p's projection; false when p is
  // behind the camera or projects outside the image.
  AMHMVS_HD bool nearestPixel(Vec3d p, int* x, int* y) const {
    if (!(p.z > 0)) return false;
    const double u = fx * p.x / p.z + cx, v = fy * p.y / p.z + cy;
    if (!(finite(u) && finite(v))) return false;
    if (!(u >= -0.5 && v >= -0.5 && u < width - 0.5 && v < height - 0.5)) return false;
    *x = static_cast<int>(floor(u + 0.5));
    *y = static_cast<int>(floor(v + 0.5));
    return *x >= 0 && *y >= 0 && *x < width && *y < height;
  }
};

// FusionOptions as the check reads them (a threshold of +infinity: off).
struct Checks {
  double max_disparity_difference;
  double max_reprojection_error;
  double max_relative_depth_difference;
  double cos_max_normal_angle;  // -2: off
  float max_cost;
  int min_consistent_views;
  bool skip_used;  // fuse_each_pixel_once
};

// What the check emits for one reference pixel, in the reference's camera
// frame. Laid out like KeyframePoint (checked in fusion_driver.h): the GPU
// downloads its points straight into the caller's KeyframePoints.
struct FusedPoint {
  float position[3];
  float normal[3];
  uint8_t rgb[3];
  float confidence;
  uint16_t consistent_views;
};

AMHMVS_HD uint8_t toByte(double value) {
  const double rounded = floor(value + 0.5);  // values are >= 0: round half up
  return static_cast<uint8_t>(rounded < 0 ? 0 : (rounded > 255 ? 255 : rounded));
}

// What one source view says about the reference pixel's world point X
// (depth `depth`, world normal `normal` at reference pixel (x, y)).
enum class SourceVerdict {
  kNotSeen,    // X is behind the source, outside its image, or on a pixel fused before (skip_used)
  kDisagrees,  // seen, but no usable estimate there or an enabled check fails
  kAgrees      // every enabled check passes
};

// The source's estimate where it sees X (filled when it agrees).
struct SourceSample {
  int pixel;      // index in the source
  Vec3d point;    // world point of that pixel at its depth (X_j)
  Vec3d normal;   // its world normal
};

// The per-view test of the consistency check (fusion.h): fusion counts and
// averages the agreeing views; the per-pixel confidence counts them.
AMHMVS_HD SourceVerdict checkSource(const ViewData& ref, const Checks& checks, int x, int y, double depth,
                                    Vec3d normal, Vec3d X, const ViewData& src, SourceSample* sample) {
  const Vec3d Xs = mul(src.R, X) + src.t;
  int sx, sy;
  if (!src.nearestPixel(Xs, &sx, &sy)) return SourceVerdict::kNotSeen;
  const int src_pixel = src.pixelIndex(sx, sy);
  // A pixel already fused elsewhere neither supports nor counts as checked.
  if (checks.skip_used && src.used && src.used[src_pixel]) return SourceVerdict::kNotSeen;
  double src_depth;
  Vec3d src_normal;
  if (!src.pixel(sx, sy, checks.max_cost, &src_depth, &src_normal)) return SourceVerdict::kDisagrees;
  if (dot(normal, src_normal) <= checks.cos_max_normal_angle) return SourceVerdict::kDisagrees;
  if (finite(checks.max_disparity_difference)) {
    // Fusibile: disparity = f_ref * baseline / depth, both depths in the source.
    const double fb = ref.fx * norm(ref.center - src.center);
    if (!(fabs(fb / Xs.z - fb / src_depth) < checks.max_disparity_difference)) return SourceVerdict::kDisagrees;
  }
  const Vec3d Xj = src.worldPoint(sx, sy, src_depth);
  if (finite(checks.max_reprojection_error) || finite(checks.max_relative_depth_difference)) {
    const Vec3d Xj_ref = mul(ref.R, Xj) + ref.t;
    if (!(Xj_ref.z > 0)) return SourceVerdict::kDisagrees;
    if (!(fabs(Xj_ref.z - depth) / depth < checks.max_relative_depth_difference)) return SourceVerdict::kDisagrees;
    const double du = ref.fx * Xj_ref.x / Xj_ref.z + ref.cx - x;
    const double dv = ref.fy * Xj_ref.y / Xj_ref.z + ref.cy - y;
    if (!(sqrt(du * du + dv * dv) < checks.max_reprojection_error)) return SourceVerdict::kDisagrees;
  }
  *sample = SourceSample{src_pixel, Xj, src_normal};
  return SourceVerdict::kAgrees;
}

// Fuses reference pixel (x, y) of `ref` against `sources[0..source_count)`.
// True when at least min_consistent_views sources agree: `out` holds the mean
// of the reference's point and the agreeing sources' points (position, unit
// normal, colour) and support[k] is the pixel index in source k that agreed,
// or -1 (support may be null when the caller keeps no marks).
AMHMVS_HD bool fusePixel(const ViewData& ref, const ViewData* sources, int source_count,
                         const Checks& checks, int x, int y, FusedPoint* out, int* support) {
  double depth;
  Vec3d normal;
  if (!ref.pixel(x, y, checks.max_cost, &depth, &normal)) return false;
  const Vec3d X = ref.worldPoint(x, y, depth);

  Vec3d sum_position = X, sum_normal = normal, sum_color{0, 0, 0};
  int colored = 0;
  if (ref.color) {
    sum_color = sum_color + ref.colorAt(x, y);
    ++colored;
  }
  int visible = 0, consistent = 0;
  for (int k = 0; k < source_count; ++k) {
    if (support) support[k] = -1;
    const ViewData& src = sources[k];
    SourceSample sample;
    const SourceVerdict verdict = checkSource(ref, checks, x, y, depth, normal, X, src, &sample);
    if (verdict == SourceVerdict::kNotSeen) continue;
    ++visible;
    if (verdict != SourceVerdict::kAgrees) continue;
    sum_position = sum_position + sample.point;
    sum_normal = sum_normal + sample.normal;
    if (src.color) {
      sum_color = sum_color + src.colorOfPixel(sample.pixel);
      ++colored;
    }
    ++consistent;
    if (support) support[k] = sample.pixel;
  }
  if (consistent < checks.min_consistent_views) return false;
  const Vec3d position = mul(ref.R, sum_position / (consistent + 1)) + ref.t;
  Vec3d mean_normal = mul(ref.R, sum_normal);
  // Opposite normals can only cancel with the angle check off.
  const double normal_length = norm(mean_normal);
  mean_normal = normal_length > 1e-9 ? mean_normal / normal_length : mul(ref.R, normal);
  if (!finite(position) || !finite(mean_normal)) return false;
  const Vec3d color = colored ? sum_color / colored : Vec3d{128, 128, 128};
  *out = FusedPoint{{float(position.x), float(position.y), float(position.z)},
                    {float(mean_normal.x), float(mean_normal.y), float(mean_normal.z)},
                    {toByte(color.x), toByte(color.y), toByte(color.z)},
                    visible ? float(consistent) / visible : 0.0f,
                    static_cast<uint16_t>(consistent)};
  return true;
}

// The views that see reference pixel (x, y)'s point and those that agree
// with it (checkSource); false (counts untouched) where the pixel has no
// usable estimate.
AMHMVS_HD bool countAgreement(const ViewData& ref, const ViewData* sources, int source_count, const Checks& checks,
                              int x, int y, int* seen, int* agreeing) {
  double depth;
  Vec3d normal;
  if (!ref.pixel(x, y, checks.max_cost, &depth, &normal)) return false;
  const Vec3d X = ref.worldPoint(x, y, depth);
  int seen_count = 0, agreeing_count = 0;
  for (int k = 0; k < source_count; ++k) {
    SourceSample sample;
    const SourceVerdict verdict = checkSource(ref, checks, x, y, depth, normal, X, sources[k], &sample);
    seen_count += verdict != SourceVerdict::kNotSeen;
    agreeing_count += verdict == SourceVerdict::kAgrees;
  }
  *seen = seen_count;
  *agreeing = agreeing_count;
  return true;
}

}  // namespace fusion
}  // namespace amhmvs
