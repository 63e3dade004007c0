// Multi-view depth-map fusion: a consistency check across depth and normal
// maps (as in Gipuma's "fusibile", paper section 3.3) that keeps a reference
// pixel's 3D point only when enough other views agree, and averages the
// agreeing points.
//
// For a reference pixel p = (u, v) of view r with depth d > 0 and normal n:
//   X     = the world point of p at depth d;
//   for every source view j of r (its `source_ids`, in order, at most
//   `max_sources`): project X into j; it must be in front (z_j(X) > 0) and
//   inside the image; q = the nearest pixel of the projection; d_j and n_j are
//   j's depth and normal at q (skipped unless finite, d_j > 0, |n_j| > 0);
//   X_j = the world point of q at depth d_j. View j AGREES when every enabled
//   check below passes; X is kept when at least `min_consistent_views` sources
//   agree. The fused point is the mean of X and all agreeing X_j (position,
//   unit normal, colour).
//
// Checks (a threshold of +infinity switches a check off):
//   max_disparity_difference (pixels) -- the paper's f_eps. Depth converted
//     to disparity for the stereo pair (r, j): disparity(z) = f_r * b_rj / z,
//     f_r = the reference's fx, b_rj = the distance between the two camera
//     centres. The check is |disparity(z_j(X)) - disparity(d_j)| < threshold,
//     i.e. the two depths of the same point along j's ray (the depth X has in
//     j and the depth j measured there) differ by less than `threshold` pixels
//     of parallax. This is exactly fusibile's definition; with the real
//     baseline the threshold is in pixels and independent of the scene's
//     scale, unlike a fixed baseline (Gipuma's stereo default 0.54 m) or a
//     unit one, which would make it a threshold in metres.
//   max_reprojection_error (pixels) -- X_j projected back into the reference
//     lands less than `threshold` pixels from p (pixel centres at integers).
//   max_relative_depth_difference -- |z_r(X_j) - d| / d < threshold, the depth
//     of X_j in the reference against the reference depth.
//   max_normal_angle_deg -- the angle between n and n_j, both rotated into
//     the world frame, is below the threshold.
//
// Presets: paper() = f_eps 0.3 px, f_ang 30 deg, f_con 2 (the paper);
// reprojection() = 2 px, 1 %, 10 deg, 2 consistent views (the public
// implementation's fusion, ACMH-style).
//
// Each pixel fused once (`fuse_each_pixel_once`, on in both presets): views
// are processed as references in ascending id. When a point is emitted, its
// reference pixel and the pixel q of every agreeing source are marked used. A
// used pixel is not a reference again and gives no support to later
// references (as the public implementation does), so a surface seen by many
// views is emitted about once, not once per view. Within one reference the
// marks of earlier references are read and its own marks are applied when it
// is done, so the result is deterministic and independent of the number of
// threads. With the option off every view is fused independently (fusibile's
// behaviour: one point per consistent pixel of every view).
//
// Output points are in the camera frame of their reference view, so that a
// later pose update of that view (e.g. after loop closure) moves them without
// recomputation; toWorld() and worldCloud() convert. NaN/inf depths or
// normals, and non-positive depths, are skipped; no non-finite point is ever
// emitted.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/keyframe_point.h"

namespace amhmvs {

// One depth map to fuse. Its images are borrowed (no copy on the way in:
// the keyframe store's own maps, or DepthMapImages); they must outlive the
// fusion call.
struct FusionView {
  int id = -1;
  PinholeCamera camera;  // at the depth map's resolution
  ImageViewF depth;      // 1 channel, z-depth (metres); NaN/inf/<= 0 = none
  ImageViewF normal;     // 3 channels, unit normals in the camera frame
  ImageViewF cost;       // optional (empty or 1 channel): see FusionOptions::max_cost
  ImageViewU8 color;     // optional (empty, 1 or 3 channels RGB), same size
  std::vector<int> source_ids;  // views to check against, best first
  // Identity of the maps' contents for a fuser that keeps them on the GPU
  // (DepthMapFuser): equal keys must mean equal depth, normal, cost and
  // colour images; -1: none (uploaded for one call). fuseDepthMaps ignores it.
  int64_t key = -1;
};

// The owned images of one depth map, for callers that read or make them
// (files, tests); borrow() makes its FusionView.
struct DepthMapImages {
  ImageF depth, normal, cost;
  ImageU8 color;
  FusionView borrow(int id, const PinholeCamera& camera) const;
};

struct FusionOptions {
  static constexpr float kOff = std::numeric_limits<float>::infinity();

  float max_disparity_difference = 0.3f;  // pixels (f_eps); see the file comment
  float max_reprojection_error = kOff;    // pixels
  float max_relative_depth_difference = kOff;  // fraction of the reference depth
  float max_normal_angle_deg = 30.0f;     // degrees (f_ang)
  int min_consistent_views = 2;           // agreeing sources needed (f_con)
  int max_sources = 0;                    // first N of source_ids; 0 = all
  // Pixels whose cost exceeds this are ignored (reference and source); used
  // only where a view has a cost map.
  float max_cost = kOff;
  bool fuse_each_pixel_once = true;

  static FusionOptions paper();
  static FusionOptions reprojection();

  // Empty when usable; otherwise what is wrong (thresholds must be > 0 or
  // +infinity, the angle at most 180 degrees, counts non-negative, at least
  // one depth check enabled).
  std::string validate() const;
};


struct FusedViewPoints {
  int view_id = -1;
  PinholeCamera camera;  // the pose the points were fused with
  KeyframePoints points;
};

struct FusionResult {
  std::vector<FusedViewPoints> views;  // one per input view, ascending id
  size_t candidate_pixels = 0;  // reference pixels with a valid depth and normal (of views with enough sources)
  size_t pointCount() const;
};

// Fuses the views. Throws InputError for: no views, repeated view ids, an
// invalid camera (PinholeCamera::validate), a depth map whose size differs
// from its camera or with channels != 1, a normal map of another size or
// channels != 3, a cost or colour image of another size or channel count, a
// source id that names no view or the view itself, repeated source ids, and
// invalid options.
FusionResult fuseDepthMaps(const std::vector<FusionView>& views, const FusionOptions& options);

// A fused point moved to the world frame with the (possibly updated) pose of
// its reference camera.
KeyframePoint toWorld(const KeyframePoint& point, const PinholeCamera& camera);

// All points in the world frame, with each view's stored camera; colours,
// normals and confidences filled.
PointCloud worldCloud(const FusionResult& result);

}  // namespace amhmvs
