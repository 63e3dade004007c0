#include "amhmvs_mapping/mapping/mapping_parameters.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/text.h"
#include "amhmvs_mapping/mapping/view_anchor.h"

namespace amhmvs {
namespace {

template <typename Options>
using Table = std::vector<OptionField<Options>>;

// A string member: any text (quotes of a yaml scalar removed by the reader).
template <typename Options>
OptionField<Options> textField(const char* name, std::string Options::*member, const char* help) {
  return {name, help, [member](const Options& o) { return o.*member; },
          [member](Options& o, const std::string& text) { o.*member = text; }};
}

// A fusion threshold: 0 switches the check off (FusionOptions::kOff, +inf,
// which a parameter server cannot carry).
OptionField<FusionOptions> thresholdField(const char* name, float FusionOptions::*member, const char* help) {
  return {name, std::string(help) + "; 0 = off",
          [member](const FusionOptions& o) {
            std::ostringstream out;
            out << (std::isinf(o.*member) ? 0.0f : o.*member);
            return out.str();
          },
          [member, name](FusionOptions& o, const std::string& text) {
            const float value = parseOptionNumber<float>(name, text);
            o.*member = value == 0 ? FusionOptions::kOff : value;
          }};
}

// A point [x, y, z]; [] (or empty) = unbounded, i.e. `unbounded` on each axis.
OptionField<VoxelMapOptions> pointField(const char* name, Eigen::Vector3d VoxelMapOptions::*member, double unbounded,
                                        const char* help) {
  return {name, help,
          [member](const VoxelMapOptions& o) {
            const Eigen::Vector3d& p = o.*member;
            if (std::isinf(p.x()) && std::isinf(p.y()) && std::isinf(p.z())) return std::string("[]");
            std::ostringstream out;
            out << "[" << p.x() << ", " << p.y() << ", " << p.z() << "]";
            return out.str();
          },
          [member, name, unbounded](VoxelMapOptions& o, const std::string& text) {
            std::string list = trimmed(text);
            if (!list.empty() && list.front() == '[' && list.back() == ']') list = list.substr(1, list.size() - 2);
            if (trimmed(list).empty()) {
              o.*member = Eigen::Vector3d::Constant(unbounded);
              return;
            }
            std::vector<double> values;
            std::istringstream items(list);
            for (std::string item; std::getline(items, item, ',');)
              values.push_back(parseOptionNumber<double>(name, trimmed(item)));
            if (values.size() != 3)
              throw InputError(std::string("option ") + name + ": '" + text + "' is not [x, y, z] or []");
            o.*member = Eigen::Vector3d(values[0], values[1], values[2]);
          }};
}

const Table<NodeOptions>& nodeTable() {
  using O = NodeOptions;
  static const Table<NodeOptions> table = {
      textField<O>("input_mode", &O::input_mode,
                   "pose: image + camera_info + pose (geometry_msgs/PoseStamped, camera-to-world of the optical "
                   "frame), approximate-time synced; odometry: the same with odom (nav_msgs/Odometry); tf: the pose "
                   "from tf2 as fixed_frame <- image frame; keyframe: amhmvs_mapping/Keyframe messages"),
      advanced(textField<O>("image_transport", &O::image_transport,
                            "image_transport of `image`: raw, or compressed (<image>/compressed, JPEG or PNG)")),
      textField<O>("fixed_frame", &O::fixed_frame, "frame of the poses and of the global map"),
      advanced(textField<O>("view_frame", &O::view_frame,
                            "static tf child of fixed_frame where the first keyframe with depth looks (the rviz "
                            "config's view target); empty: not published")),
      advanced(textField<O>("view_up", &O::view_up,
                            "the world direction view_frame's z takes (up in rviz): auto (world z when the first "
                            "keyframe's camera is within 70 deg of upright in it, else the world axis nearest its "
                            "up: a world that is a camera frame) or X,Y,Z")),
      advanced(numberField("tf_timeout", &O::tf_timeout,
                           "tf mode: wall seconds a frame waits for its transform (no callback blocks)")),
      advanced(numberField("sync_queue_size", &O::sync_queue_size, "approximate-time synchroniser queue")),
      advanced(numberField("sync_max_interval", &O::sync_max_interval,
                           "largest stamp difference of synchronised messages, seconds")),
      advanced(switchField<O>("publish_depth_mm", &O::publish_depth_mm,
                              "also publish depth_mm/image + camera_info: 16UC1 millimetres, 0 = invalid")),
      advanced(numberField("map_publish_period", &O::map_publish_period,
                           "at most one publication of the latched map per this many seconds, when it changed")),
      advanced(numberField("diagnostics_period", &O::diagnostics_period, "seconds between /diagnostics updates")),
      advanced(numberField("silence_timeout", &O::silence_timeout,
                           "seconds: an input topic silent this long while the others deliver is reported")),
      advanced(numberField("drop_warning_window", &O::drop_warning_window,
                           "seconds: diagnostics WARN while inputs were dropped within this window")),
      textField<O>("map_directory", &O::map_directory,
                   "where ~save_map writes relative paths; empty: the directory roslaunch was started from"),
      textField<O>("save_map_on_shutdown", &O::save_map_on_shutdown,
                   "a .ply or .pcd file (relative: under map_directory) the global map is written to when the node "
                   "shuts down (Ctrl-C on roslaunch); empty: not saved"),
  };
  return table;
}

const Table<PipelineOptions>& pipelineTable() {
  using O = PipelineOptions;
  static const Table<PipelineOptions> table = {
      {"backend", "auto (CUDA when a GPU is usable, else the CPU, logged), cuda or cpu",
       [](const O& o) { return std::string(backendName(o.backend)); },
       [](O& o, const std::string& text) { o.backend = parseBackend(text); }},
      numberField("queue_size", &O::queue_size,
                  "keyframes waiting for the estimator; when full the oldest is dropped (counted). amhmvs_map "
                  "offline (no --realtime): every keyframe waits unless this is given"),
      advanced(switchField<O>("skip_to_newest", &O::skip_to_newest,
                              "after a queue overflow take the newest keyframe next and drop the older queued ones")),
  };
  return table;
}

const Table<KeyframePickerOptions>& keyframeTable() {
  using O = KeyframePickerOptions;
  static const Table<KeyframePickerOptions> table = {
      numberField("keyframe_min_translation", &O::min_translation_m,
                  "a frame is a keyframe candidate after this much motion since the last keyframe, metres ..."),
      numberField("keyframe_min_rotation_deg", &O::min_rotation_deg, "... or this much rotation, degrees (both 0: all)"),
      advanced(numberField("keyframe_min_turning_translation", &O::min_turning_translation_fraction,
                           "a candidate that turned but moved less than this fraction of keyframe_min_translation "
                           "is a pure rotation, refused (0: off)")),
      advanced(numberField("keyframe_min_relative_sharpness", &O::min_relative_sharpness,
                           "a candidate blurrier than this fraction of the recent candidates' median sharpness is "
                           "refused, the next frame tried; 4 in a row: taken anyway (0: off)")),
  };
  return table;
}

const Table<KeyframeStoreOptions>& storeTable() {
  using O = KeyframeStoreOptions;
  static const Table<KeyframeStoreOptions> table = {
      numberField("max_keyframes", &O::max_keyframes, "keyframes kept as source views; the oldest are evicted"),
      {"max_memory_mb", "MiB of images, depth maps and points kept; 0 = no bound",
       [](const O& o) {
         if (o.max_bytes == std::numeric_limits<size_t>::max()) return std::string("0");
         std::ostringstream out;
         out << static_cast<double>(o.max_bytes) / (1 << 20);
         return out.str();
       },
       [](O& o, const std::string& text) {
         const double mib = parseOptionNumber<double>("max_memory_mb", text);
         if (!(mib >= 0) || !std::isfinite(mib)) throw InputError("option max_memory_mb: '" + text + "' must be >= 0");
         o.max_bytes = mib == 0 ? std::numeric_limits<size_t>::max() : static_cast<size_t>(mib * (1 << 20));
       }},
  };
  return table;
}

const Table<SourceSelectionOptions>& sourcesTable() {
  using O = SourceSelectionOptions;
  static const Table<SourceSelectionOptions> table = {
      withAlias(numberField<O, int>("max_sources", &O::max_sources, "source views per keyframe, at most"),
                "num_sources"),
      withAlias(advanced(numberField<O, double>("min_triangulation_angle_deg", &O::min_triangulation_angle_deg,
                                                "median ray angle at the scene depth, lower bound")),
                "min_triangulation_angle_deg"),
      advanced(numberField<O, double>("max_triangulation_angle_deg", &O::max_triangulation_angle_deg,
                                      "median ray angle at the scene depth, upper bound")),
      advanced(numberField<O, double>("max_axis_angle_deg", &O::max_axis_angle_deg, "between the optical axes")),
      advanced(numberField<O, double>("min_overlap", &O::min_overlap, "fraction of the new image seen by the source")),
      withAlias(advanced(numberField<O, double>("preferred_angle_deg", &O::preferred_angle_deg,
                                                "best triangulation angle of the ranking")),
                "preferred_angle_deg"),
      advanced(numberField<O, int>("max_candidates", &O::max_candidates,
                                   "stored keyframes evaluated in full per selection (the overlap grid), the best "
                                   "at the image centre among the four times as many nearest; bounds the cost as the "
                                   "store grows")),
      advanced(switchField<O>("match_when_unknown", &O::match_when_unknown,
                              "the first pair's scene depth from patches matched along epipolar lines")),
      withAlias(advanced(numberField<O, double>("default_scene_depth", &O::default_scene_depth,
                                                "last-resort scene depth for the ranking, metres")),
                "scene_depth"),
  };
  return table;
}

const Table<DepthRangeOptions>& depthRangeTable() {
  using O = DepthRangeOptions;
  static const Table<DepthRangeOptions> table = {
      advanced(switchField<O>("use_given_range", &O::use_given_range,
                              "use Keyframe.msg min_depth/max_depth when both > 0")),
      advanced(numberField("near_factor", &O::near_factor, "widen the estimated near limit by this factor")),
      advanced(numberField("far_factor", &O::far_factor, "widen the estimated far limit by this factor")),
      advanced(numberField("min_sparse_points", &O::min_sparse_points, "sparse points in view for a range from them")),
      advanced(numberField("min_depth_samples", &O::min_depth_samples,
                           "reprojected source depths for a range from them")),
      advanced(numberField("max_neighbour_cost", &O::max_neighbour_cost,
                           "matching cost (0..2) of a confident source pixel, at most")),
      advanced(numberField("neighbour_low_percentile", &O::neighbour_low_percentile,
                           "near limit: this percentile of the sources' depths x near_factor")),
      advanced(numberField("neighbour_high_percentile", &O::neighbour_high_percentile,
                           "far limit: this percentile x far_factor")),
      advanced(switchField<O>("match_when_unknown", &O::match_when_unknown,
                              "the first pair's range from patches matched along epipolar lines")),
      numberField("default_min", &O::default_min, "the last-resort range, metres: near ..."),
      numberField("default_max", &O::default_max, "... and far"),
  };
  return table;
}

const Table<FusionOptions>& fusionTable() {
  using O = FusionOptions;
  static const Table<FusionOptions> table = {
      withAlias(advanced(thresholdField("max_reprojection_error", &O::max_reprojection_error, "pixels")),
                "fusion_max_reprojection_error"),
      withAlias(thresholdField("max_relative_depth_difference", &O::max_relative_depth_difference,
                               "fraction of the depth"),
                "fusion_max_relative_depth_difference"),
      advanced(thresholdField("max_disparity_difference", &O::max_disparity_difference, "pixels (the paper's f_eps)")),
      withAlias(thresholdField("max_normal_angle_deg", &O::max_normal_angle_deg, "degrees"),
                "fusion_max_normal_angle_deg"),
      withAlias(numberField("min_consistent_views", &O::min_consistent_views,
                            "agreeing other keyframes needed; a keyframe waits for them (at most 32)"),
                "fusion_min_consistent_views"),
      withAlias(advanced(thresholdField("max_cost", &O::max_cost,
                                        "pixels with a matching cost (0..2) above this are not fused")),
                "fusion_max_cost"),
  };
  return table;
}

const Table<VoxelMapOptions>& mapTable() {
  using O = VoxelMapOptions;
  const double inf = std::numeric_limits<double>::infinity();
  static const Table<VoxelMapOptions> table = {
      withAlias(numberField("voxel_size", &O::leaf_size, "voxel edge, metres"), "voxel_size"),
      advanced(numberField("max_voxels", &O::max_voxels,
                           "voxels kept; beyond, the oldest reposable keyframes' points are removed, then new points dropped")),
      advanced(numberField("reposable_keyframes", &O::reposable_keyframes,
                           "newest keyframes whose points are kept so that loop closures can move them; older ones "
                           "are frozen (they stay in the map, fixed)")),
      withAlias(numberField("min_points_per_voxel", &O::min_points_per_voxel,
                            "voxels with fewer fused points are kept but not published (1: every voxel)"),
                "min_points_per_voxel"),
      advanced(pointField("region_min", &O::region_min, -inf,
                          "region of interest in fixed_frame, [x, y, z] .. region_max; [] = unbounded")),
      advanced(pointField("region_max", &O::region_max, inf, "its upper corner; [] = unbounded")),
  };
  return table;
}

const Table<TsdfMapOptions>& surfaceTable() {
  using O = TsdfMapOptions;
  static const Table<TsdfMapOptions> table = {
      switchField<O>("enabled", &O::enabled,
                     "integrate the published depth into a TSDF surface map and publish its mesh (needs confidence/enabled)"),
      numberField("voxel_size", &O::voxel_size, "surface map voxel edge, metres"),
      advanced(numberField("band_voxels", &O::band_voxels, "truncation band, voxels (> 1)")),
      advanced(numberField("max_image_width", &O::max_image_width,
                           "wider depth images are subsampled to at most this width before integration")),
      advanced(numberField("min_weight", &O::min_weight,
                           "voxels with less weight (sum of confidences) are unobserved: no surface through them")),
      advanced(numberField("max_blocks", &O::max_blocks,
                           "8^3-voxel blocks kept (16 KiB each); beyond, the oldest reposable keyframes are removed, "
                           "then new blocks dropped")),
      advanced(numberField("reposable_keyframes", &O::reposable_keyframes,
                           "newest keyframes whose depth is kept so that loop closures can move them; older ones are "
                           "frozen (they stay in the surface, fixed)")),
  };
  return table;
}

const Table<RefinementOptions>& refinementTable() {
  using O = RefinementOptions;
  static const Table<RefinementOptions> table = {
      advanced(numberField("max_refinements", &O::max_refinements,
                           "re-estimates of a keyframe when later keyframes give it better sources; 0 = off")),
      advanced(numberField("min_score_gain", &O::min_score_gain,
                           "re-estimate when the selection's score grew by this factor")),
      advanced(switchField<O>("keep_only_better", &O::keep_only_better,
                              "keep a refined depth map only when it has not fewer confident pixels")),
      advanced(numberField("confident_cost", &O::confident_cost, "keep_only_better: a confident pixel's cost")),
      advanced(numberField("max_confident_loss", &O::max_confident_loss,
                           "keep_only_better: fraction of confident pixels a refinement may lose")),
      withAlias(advanced(switchField<O>("fuse_neighbours_again", &O::fuse_neighbours_again,
                                        "fuse a keyframe again when a refinement replaced one of its "
                                        "consistency views' depth maps")),
                "fuse_neighbours_again"),
  };
  return table;
}

const Table<ConfidenceOptions>& confidenceTable() {
  using O = ConfidenceOptions;
  static const Table<ConfidenceOptions> table = {
      withAlias(switchField<O>("enabled", &O::enabled,
                               "a calibrated per-pixel confidence when a keyframe is fused; its depth published "
                               "then, masked (false: unmasked as soon as estimated)"),
                "confidence"),
      withAlias(numberField("min_probability", &O::min_probability,
                            "published depth: NaN where the probability of being within 5 % is below this "
                            "(0: nothing masked)"),
                "confidence_level"),
      withAlias(advanced(switchField<O>("again_with_more_views", &O::again_with_more_views,
                                        "fuse and publish a keyframe again when more views see it than when it "
                                        "was fused (idle work)")),
                "confidence_again_with_more_views"),
  };
  return table;
}

const Table<NeighbourDepthOptions>& neighbourDepthTable() {
  using O = NeighbourDepthOptions;
  static const Table<NeighbourDepthOptions> table = {
      withAlias(advanced(OptionField<O>{"start_from_neighbours",
                                 "a keyframe's estimate starts from its sources' depth maps: true, false or auto "
                                 "(on with the CPU estimator; on CUDA its reprojection on the host would cost more "
                                 "than the estimate)",
                                 [](const O& o) { return std::string(neighbourStartName(o.start_from_neighbours)); },
                                 [](O& o, const std::string& text) { o.start_from_neighbours = parseNeighbourStart(text); },
                                 /*is_switch=*/true}),
                "start_from_neighbours"),
      withAlias(advanced(numberField("start_iterations", &O::start_iterations,
                                     "iterations from that start (0: the estimator's schedule)")),
                "start_iterations"),
      withAlias(advanced(numberField("start_max_cost", &O::start_max_cost,
                                     "source pixels with a matching cost above this are not carried")),
                "start_max_cost"),
      withAlias(advanced(switchField<O>("geometric_refinement", &O::geometric_refinement,
                                        "a refinement adds the geometric-consistency term against its sources")),
                "geometric_refinement"),
      withAlias(advanced(numberField("geometric_iterations", &O::geometric_iterations,
                                     "its iterations of local refinement")),
                "geometric_refinement_iterations"),
  };
  return table;
}

const Table<RollingShutterOptions>& rollingShutterTable() {
  using O = RollingShutterOptions;
  static const Table<RollingShutterOptions> table = {
      withAlias(numberField("readout_s", &O::readout_s,
                            "rolling-shutter readout, first to last row, seconds; 0 = global shutter"),
                "rolling_shutter_s"),
      withAlias(advanced(numberField("max_interval_s", &O::max_interval_s,
                                     "the keyframe before must be at most this long before to tell the motion")),
                "rolling_shutter_max_interval_s"),
  };
  return table;
}

const Table<TemporalDepthOptions>& depthFilterTable() {
  using O = TemporalDepthOptions;
  static const Table<TemporalDepthOptions> table = {
      switchField<O>("enabled", &O::enabled,
                     "refine each keyframe's depth with the frames that follow it (a per-pixel depth filter) and "
                     "publish it again"),
      advanced(numberField("keyframes", &O::keyframes, "the newest keyframes with a depth map that each frame refines")),
      advanced(numberField("frames_per_keyframe", &O::frames_per_keyframe,
                           "frames one keyframe's filter takes; then its depth is final")),
      advanced(numberField("publish_every", &O::publish_every,
                           "a keyframe's depth is published again after this many frames")),
  };
  return table;
}

const Table<DepthFilterOptions>& depthFilterPixelTable() {
  using O = DepthFilterOptions;
  static const Table<DepthFilterOptions> table = {
      advanced(numberField("initial_sigma", &O::initial_sigma,
                           "the filter's start: sigma of the estimated depth, relative to it")),
      advanced(numberField("pixel_sigma", &O::pixel_sigma, "a measurement's matching error, pixels")),
      advanced(numberField("search_sigmas", &O::search_sigmas, "each frame searches +- this many sigma")),
      advanced(numberField("search_samples", &O::search_samples, "depths tried along that epipolar segment")),
      advanced(numberField("max_cost", &O::max_cost, "a match needs a matching cost (0..2) below this")),
      advanced(numberField("converged_sigma", &O::converged_sigma,
                           "published where sigma is at most this, relative to the depth")),
      advanced(numberField("min_inlier_probability", &O::min_inlier_probability,
                           "...and the probability that the pixel's measurements are inliers is at least this")),
  };
  return table;
}

// The estimator's and the pose refinement's own tables, with the older
// command-line names amhmvs_map and amhmvs_depth take (--iterations,
// --pose_refinement_max_features, --pose_refinement).
const std::set<std::string> kEssentialEstimatorOptions = {"iterations", "multiscale", "multiscale_iterations"};

Table<PatchMatchOptions> estimatorTable() {
  Table<PatchMatchOptions> table = patchMatchOptionTable();
  for (OptionField<PatchMatchOptions>& field : table) {
    field.alias = field.name;
    field.advanced = !kEssentialEstimatorOptions.count(field.name);
  }
  return table;
}

// A group switched by "enabled" (--GROUP; its other fields --GROUP_NAME, advanced).
template <typename Options>
Table<Options> switchedGroupTable(Table<Options> table, const std::string& group) {
  for (OptionField<Options>& field : table) {
    field.alias = field.name == "enabled" ? group : group + "_" + field.name;
    field.advanced = field.name != "enabled";
  }
  return table;
}

template <typename Inner>
void append(Table<MappingParameters>* table, const std::string& group, Inner& (*member)(MappingParameters&),
            const Table<Inner>& fields) {
  for (OptionField<MappingParameters>& field : nestedFields(group, member, fields)) {
    if (group.empty()) field.name = field.name.substr(1);  // "/name" at the top level
    table->push_back(std::move(field));
  }
}

NodeOptions& nodeOf(MappingParameters& p) { return p.node; }
PipelineOptions& pipelineOf(MappingParameters& p) { return p.pipeline; }
KeyframePickerOptions& keyframesOf(MappingParameters& p) { return p.keyframes; }
KeyframeStoreOptions& storeOf(MappingParameters& p) { return p.pipeline.mapper.store; }
SourceSelectionOptions& sourcesOf(MappingParameters& p) { return p.pipeline.mapper.sources; }
DepthRangeOptions& depthRangeOf(MappingParameters& p) { return p.pipeline.mapper.depth_range; }
FusionOptions& fusionOf(MappingParameters& p) { return p.pipeline.mapper.fusion; }
VoxelMapOptions& mapOf(MappingParameters& p) { return p.pipeline.mapper.map; }
RefinementOptions& refinementOf(MappingParameters& p) { return p.pipeline.mapper.refinement; }
TsdfMapOptions& surfaceOf(MappingParameters& p) { return p.pipeline.mapper.surface; }
ConfidenceOptions& confidenceOf(MappingParameters& p) { return p.pipeline.mapper.confidence; }
PoseRefinementOptions& poseRefinementOf(MappingParameters& p) { return p.pipeline.mapper.pose_refinement; }
DirectAlignmentOptions& directAlignmentOf(MappingParameters& p) { return p.pipeline.mapper.direct_alignment; }
NeighbourDepthOptions& neighbourDepthOf(MappingParameters& p) { return p.pipeline.mapper.neighbour_depth; }
RollingShutterOptions& rollingShutterOf(MappingParameters& p) { return p.pipeline.mapper.rolling_shutter; }
TemporalDepthOptions& depthFilterOf(MappingParameters& p) { return p.pipeline.mapper.depth_filter; }
DepthFilterOptions& depthFilterPixelOf(MappingParameters& p) { return p.pipeline.mapper.depth_filter.filter; }
PatchMatchOptions& estimatorOf(MappingParameters& p) { return p.pipeline.estimator; }

Table<MappingParameters> buildTable() {
  Table<MappingParameters> table;
  append(&table, "", nodeOf, nodeTable());
  append(&table, "", keyframesOf, keyframeTable());
  append(&table, "", pipelineOf, pipelineTable());
  table.push_back({"max_image_size",
                   "longest processed image side: 0 = full size, -1 = auto (full size on the GPU, 320 on the CPU)",
                   [](const MappingParameters& p) { return std::to_string(p.max_image_size); },
                   [](MappingParameters& p, const std::string& text) {
                     p.max_image_size = parseOptionNumber<int>("max_image_size", text);
                   }});
  append(&table, "store", storeOf, storeTable());
  append(&table, "sources", sourcesOf, sourcesTable());
  append(&table, "depth_range", depthRangeOf, depthRangeTable());
  append(&table, "fusion", fusionOf, fusionTable());
  append(&table, "map", mapOf, mapTable());
  append(&table, "surface", surfaceOf, surfaceTable());
  append(&table, "refinement", refinementOf, refinementTable());
  append(&table, "confidence", confidenceOf, confidenceTable());
  append(&table, "direct_alignment", directAlignmentOf,
         switchedGroupTable(directAlignmentOptionTable(), "direct_alignment"));
  append(&table, "pose_refinement", poseRefinementOf,
         switchedGroupTable(poseRefinementOptionTable(), "pose_refinement"));
  append(&table, "neighbour_depth", neighbourDepthOf, neighbourDepthTable());
  append(&table, "rolling_shutter", rollingShutterOf, rollingShutterTable());
  append(&table, "depth_filter", depthFilterOf, depthFilterTable());
  append(&table, "depth_filter", depthFilterPixelOf, depthFilterPixelTable());
  append(&table, "estimator", estimatorOf, estimatorTable());
  return table;
}

std::string groupOf(const std::string& name) {
  const size_t slash = name.find('/');
  return slash == std::string::npos ? "" : name.substr(0, slash);
}

std::string leafOf(const std::string& name) { return name.substr(name.find('/') + 1); }

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// A yaml scalar as text: quotes removed.
std::string scalarText(const std::string& value) {
  if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') && value.back() == value.front())
    return value.substr(1, value.size() - 2);
  return value;
}

// The value part of a line without its trailing comment (not inside quotes or a list).
std::string withoutComment(const std::string& text) {
  char quote = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    if (quote) {
      if (text[i] == quote) quote = 0;
    } else if (text[i] == '"' || text[i] == '\'') {
      quote = text[i];
    } else if (text[i] == '#' && (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\t')) {
      return text.substr(0, i);
    }
  }
  return text;
}

// A yaml line of the table's layout as "key: value # help", aligned.
std::string yamlLine(const std::string& indent, const std::string& key, const std::string& value,
                     const std::string& help) {
  std::string text = value.empty() ? "\"\"" : value;
  std::string line = indent + key + ": " + text;
  if (line.size() < 40) line.resize(40, ' ');
  return line + "  # " + help + "\n";
}

}  // namespace

std::string NodeOptions::validate() const {
  std::ostringstream why;
  auto require = [&why](bool ok, const char* problem) {
    if (!ok) why << problem << "\n";
  };
  require(input_mode == "pose" || input_mode == "odometry" || input_mode == "tf" || input_mode == "keyframe",
          "input_mode must be pose, odometry, tf or keyframe");
  require(!fixed_frame.empty(), "fixed_frame must not be empty");
  const std::string view_up_problem = validateViewUp(view_up);
  if (!view_up_problem.empty()) why << view_up_problem << "\n";
  require(tf_timeout >= 0, "tf_timeout must be >= 0");
  require(sync_queue_size >= 1, "sync_queue_size must be >= 1");
  require(sync_max_interval >= 0, "sync_max_interval must be >= 0");
  require(map_publish_period > 0, "map_publish_period must be > 0");
  require(diagnostics_period > 0, "diagnostics_period must be > 0");
  require(silence_timeout > 0, "silence_timeout must be > 0");
  require(drop_warning_window > 0, "drop_warning_window must be > 0");
  return why.str();
}

MappingParameters::MappingParameters() {
  // Online on real video with a bounded store: the per-keyframe cost and the
  // memory stay flat, and 4 sources halve the CPU's time per keyframe.
  pipeline.mapper.store.max_keyframes = 50;
  pipeline.mapper.store.max_bytes = size_t{1} << 30;
  pipeline.mapper.sources.max_sources = 4;
  // Pixels the estimator itself doubts (cost above 0.6 of 2) stay out of the map.
  pipeline.mapper.fusion.max_cost = 0.6f;
  // Two scales, one iteration at the finer one: on redkitchen (real video,
  // KinectFusion's and an odometry's poses, CPU at 320 px and GPU at 640 px)
  // more estimates within 5 %, more published depth and a larger map at the
  // same accuracy, in half the CPU time (docs/accuracy.md). The estimator's
  // own default stays the paper's single scale (amhmvs_depth).
  pipeline.estimator.multiscale_levels = 2;
  pipeline.estimator.multiscale_iterations = 1;
  // Holds a bag's burst of keyframes while the CPU estimates for seconds.
  pipeline.queue_size = 32;
}

std::string MappingParameters::validate() const {
  std::ostringstream why;
  appendProblems("node", node.validate(), &why);
  why << pipeline.validate();
  appendProblems("keyframe picking", keyframes.validate(), &why);
  if (!validMaxImageSize(max_image_size))
    why << "max_image_size must be -1 (auto), 0 (full size) or >= 16 (got " << max_image_size << ")\n";
  return why.str();
}

const std::vector<MappingParameter>& mappingParameterTable() {
  static const std::vector<MappingParameter> table = buildTable();
  return table;
}

const std::vector<ParameterGroup>& mappingParameterGroups() {
  static const std::vector<ParameterGroup> groups = {
      {"", "Input, keyframe picking, backend and image size"},
      {"store", "Keyframe store (mapping/keyframe_store.h): the keyframes kept as source views; beyond either bound "
                "the oldest are evicted (their map points stay)"},
      {"sources", "Source views (mapping/source_selection.h): stored keyframes ranked by overlap and triangulation "
                  "angle at the new keyframe's scene depth"},
      {"depth_range", "Depth range of a keyframe (mapping/depth_range.h): its own, else its sparse points, else the "
                      "sources' depth maps, else patches matched along epipolar lines, else default_min..max"},
      {"fusion", "Fusion against other keyframes' depth maps (mapping/fusion.h); a keyframe is fused once "
                 "min_consistent_views others pass the sources' geometric checks against it"},
      {"map", "Global voxel map (mapping/voxel_map.h), published on `map`"},
      {"surface", "Surface map (mapping/tsdf_map.h): a TSDF of the published depth, weighted by its confidence, and "
                  "its mesh, published on `mesh` and `surface`"},
      {"refinement", "Re-estimation of a keyframe when later keyframes give it better sources (idle work)"},
      {"confidence", "Calibrated confidence and the published depth (mapping/depth_confidence.h)"},
      {"direct_alignment", "Direct alignment before stereo (mapping/direct_alignment.h, not in the paper): each "
                           "source with a depth map aligned to the keyframe photometrically, coarse to fine"},
      {"pose_refinement", "Pose refinement before stereo (mapping/pose_refinement.h): SIFT features and a bundle "
                          "adjustment with the tracker's noise as the prior; needs OpenCV features2d and Ceres"},
      {"neighbour_depth", "The neighbours' depth maps as the estimator's start (mapping/neighbour_depth.h)"},
      {"rolling_shutter", "Rolling-shutter rectification of each keyframe image (mapping/rolling_shutter.h)"},
      {"depth_filter", "Temporal depth filter (mapping/temporal_depth.h, not in the paper): each keyframe's depth "
                       "refined by the frames that follow it and published again"},
      {"estimator", "AMHMVS estimator (mvs/patchmatch_options.h; the paper's defaults but two scales, see multiscale)"},
  };
  return groups;
}

const MappingParameter* findMappingParameter(const std::string& name) {
  for (const MappingParameter& parameter : mappingParameterTable())
    if (parameter.name == name) return &parameter;
  return nullptr;
}

const MappingParameter* findMappingParameterByAlias(const std::string& alias) {
  for (const MappingParameter& parameter : mappingParameterTable())
    if (!parameter.alias.empty() && parameter.alias == alias) return &parameter;
  return nullptr;
}

bool isNodeParameter(const MappingParameter& parameter) {
  for (const OptionField<NodeOptions>& field : nodeTable())
    if (field.name == parameter.name) return true;
  return false;
}

std::string closestParameterName(const std::string& name) {
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const MappingParameter& parameter : mappingParameterTable()) {
    for (const std::string& candidate : {parameter.name, leafOf(parameter.name)}) {
      const size_t distance = editDistance(name, candidate);
      if (distance < best_distance) {
        best_distance = distance;
        best = parameter.name;
      }
    }
  }
  return best;
}

void setMappingParameter(const std::string& name, const std::string& value, MappingParameters* parameters) {
  const MappingParameter* parameter = findMappingParameter(name);
  if (!parameter)
    throw InputError("unknown parameter '" + name + "' (did you mean '" + closestParameterName(name) + "'?)");
  try {
    parameter->set(*parameters, value);
  } catch (const InputError& e) {
    throw InputError("parameter " + parameter->name + " = '" + value + "': " + e.what());
  }
}

std::string mappingParametersYaml() {
  const MappingParameters defaults;
  std::ostringstream out;
  out << "# Parameters of amhmvs_mapping: the nodelet's private namespace (launch/mapping.launch loads this\n"
         "# file) and amhmvs_map --config. Every value is the default. Generated from the parameter table\n"
         "# (src/mapping/mapping_parameters.cpp): amhmvs_map --print_parameters yaml > config/mapping.yaml.\n"
         "# Reference: docs/parameters.md. (advanced): tuning most users never need.\n";
  for (const ParameterGroup& group : mappingParameterGroups()) {
    out << "\n# --- " << group.description << "\n";
    if (!group.name.empty()) out << group.name << ":\n";
    const std::string indent = group.name.empty() ? "" : "  ";
    for (const MappingParameter& parameter : mappingParameterTable()) {
      if (groupOf(parameter.name) != group.name) continue;
      out << yamlLine(indent, leafOf(parameter.name), parameter.get(defaults),
                      (parameter.advanced ? "(advanced) " : "") + parameter.help);
    }
  }
  return out.str();
}

std::string mappingParametersMarkdown() {
  const MappingParameters defaults;
  std::ostringstream out;
  out << "# Parameters\n\n"
         "Every parameter of the mapping nodelet (ROS: `~name`, `~group/name`) and of `amhmvs_map`\n"
         "(`--config FILE`, `--set group/name=value`, `--group/name value`; the older flag in the last column\n"
         "still works). The same defaults run in both; `config/mapping.yaml` lists them all. This page is\n"
         "generated from the parameter table (`src/mapping/mapping_parameters.cpp`) by\n"
         "`amhmvs_map --print_parameters markdown`; a test fails when it, the yaml or the table disagree.\n\n"
         "Most users set only the parameters in bold; the rest are advanced.\n";
  for (const ParameterGroup& group : mappingParameterGroups()) {
    out << "\n## " << (group.name.empty() ? "Top level" : "`" + group.name + "/`") << "\n\n"
        << group.description << ".\n\n| parameter | default | meaning | amhmvs_map flag |\n| --- | --- | --- | --- |\n";
    for (const MappingParameter& parameter : mappingParameterTable()) {
      if (groupOf(parameter.name) != group.name) continue;
      const std::string value = parameter.get(defaults);
      const std::string name = "`" + parameter.name + "`";
      std::string help = parameter.help;
      std::replace(help.begin(), help.end(), '|', '/');
      out << "| " << (parameter.advanced ? name : "**" + name + "**") << " | `" << (value.empty() ? "\"\"" : value)
          << "` | " << help << " | " << (parameter.alias.empty() ? "" : "`--" + parameter.alias + "`") << " |\n";
    }
  }
  return out.str();
}

std::vector<std::pair<std::string, std::string>> readParameterFile(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw InputError("cannot read parameter file " + path);
  std::vector<std::pair<std::string, std::string>> settings;
  std::string group;
  int number = 0;
  for (std::string line; std::getline(file, line);) {
    ++number;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    const std::string content = withoutComment(line);
    if (trimmed(content).empty()) continue;
    const bool indented = content[0] == ' ';
    const size_t colon = content.find(':');
    if (colon == std::string::npos) throw InputError(where + "expected 'name: value', got '" + trimmed(line) + "'");
    const std::string key = trimmed(content.substr(0, colon));
    const std::string value = trimmed(content.substr(colon + 1));
    if (key.empty() || key.find_first_of(" \t/") != std::string::npos)
      throw InputError(where + "'" + key + "' is not a parameter name");
    if (!indented) {
      group.clear();
      if (value.empty()) {
        group = key;  // a group's header
        continue;
      }
      settings.emplace_back(key, scalarText(value));
      continue;
    }
    if (group.empty()) throw InputError(where + "an indented line outside a group");
    if (value.empty()) throw InputError(where + group + "/" + key + " has no value (nested groups are not read)");
    settings.emplace_back(group + "/" + key, scalarText(value));
  }
  return settings;
}

std::vector<std::string> applyParameterFile(const std::string& path, MappingParameters* parameters) {
  std::vector<std::string> names;
  for (const auto& setting : readParameterFile(path)) {
    try {
      setMappingParameter(setting.first, setting.second, parameters);
    } catch (const InputError& e) {
      throw InputError(path + ": " + e.what());
    }
    names.push_back(setting.first);
  }
  return names;
}

bool validMaxImageSize(int configured) { return configured == -1 || configured == 0 || configured >= 16; }

int effectiveMaxImageSize(int configured, Backend backend) {
  if (configured != -1) return configured;
  return backend == Backend::kCpu ? kCpuAutoMaxImageSize : 0;
}

}  // namespace amhmvs
