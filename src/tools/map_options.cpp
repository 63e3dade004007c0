#include "map_options.h"

#include <cmath>
#include <sstream>

#include "tool_options.h"

namespace amhmvs {

namespace {

// --pose_refinement_<name>: an option of poseRefinementOptionTable().
const std::string kPoseRefinementPrefix = "pose_refinement_";

// "x,y,z" in metres.
Eigen::Vector3d parseVector(const std::string& option, const std::string& text) {
  std::istringstream in(text);
  std::string item;
  std::vector<double> values;
  while (std::getline(in, item, ',')) values.push_back(parseValue<double>(option, item));
  if (values.size() != 3) throw InputError("option --" + option + ": expected x,y,z, got '" + text + "'");
  return {values[0], values[1], values[2]};
}

// A fusion threshold: 0 switches the check off (as in config/mapping.yaml).
float parseThreshold(const std::string& option, const std::string& text) {
  const float value = parseValue<float>(option, text);
  return value == 0 ? FusionOptions::kOff : value;
}

// The fusion and confidence options, by name; false when `name` is neither.
bool setFusionOption(const std::string& name, const std::string& value, OnlineMapperOptions* mapper) {
  FusionOptions& fusion = mapper->fusion;
  if (name == "fusion_max_reprojection_error") fusion.max_reprojection_error = parseThreshold(name, value);
  else if (name == "fusion_max_relative_depth_difference")
    fusion.max_relative_depth_difference = parseThreshold(name, value);
  else if (name == "fusion_max_normal_angle_deg") fusion.max_normal_angle_deg = parseThreshold(name, value);
  else if (name == "fusion_max_cost") fusion.max_cost = parseThreshold(name, value);
  else if (name == "fusion_min_consistent_views") fusion.min_consistent_views = parseValue<int>(name, value);
  else if (name == "confidence") mapper->confidence.enabled = parseSwitch(name, value);
  else if (name == "confidence_level") mapper->confidence.min_probability = parseValue<float>(name, value);
  else if (name == "confidence_again_with_more_views")
    mapper->confidence.again_with_more_views = parseSwitch(name, value);
  else if (name == "fuse_neighbours_again") mapper->refinement.fuse_neighbours_again = parseSwitch(name, value);
  else if (name == "rolling_shutter_s") mapper->rolling_shutter.readout_s = parseValue<double>(name, value);
  else if (name == "rolling_shutter_velocity")
    mapper->rolling_shutter.use_tracker_velocity = parseSwitch(name, value);
  else if (name == "rolling_shutter_translation") mapper->rolling_shutter.translation = parseSwitch(name, value);
  else if (name == "rolling_shutter_from_adjusted_poses")
    mapper->rolling_shutter.from_adjusted_poses = parseSwitch(name, value);
  else if (name == "rolling_shutter_velocity_sigma_rad_s")
    mapper->rolling_shutter.tracker_velocity_sigma_rad_s = parseValue<double>(name, value);
  else if (name == "rolling_shutter_velocity_sigma_m_s")
    mapper->rolling_shutter.tracker_velocity_sigma_m_s = parseValue<double>(name, value);
  else if (name == "rolling_shutter_max_interval_s")
    mapper->rolling_shutter.max_interval_s = parseValue<double>(name, value);
  else return false;
  return true;
}

}  // namespace

MapToolOptions parseMapToolArguments(const std::vector<std::string>& arguments) {
  MapToolOptions options;
  PipelineOptions& pipeline = options.pipeline;
  FrameSelection& frames = options.frames;
  PosedSequenceOptions& sequence = options.sequence;
  bool pose_refinement_asked = false;  // given on the command line (not the default)
  NeighbourDepthOptions& neighbours = pipeline.mapper.neighbour_depth;
  for (size_t i = 0; i < arguments.size(); ++i) {
    std::string name, value;
    nextOption(arguments, &i,
               {"quiet", "write_depth", "write_previews", "write_clouds", "write_confidence", "skip_to_newest",
                "confidence", "confidence_again_with_more_views", "fuse_neighbours_again", "pose_refinement", "start_from_neighbours",
                "geometric_refinement", "rolling_shutter_velocity", "rolling_shutter_translation",
                "rolling_shutter_from_adjusted_poses"},
               &name, &value);
    if (name == "quiet") options.quiet = parseSwitch(name, value);
    else if (name == "write_depth") options.write_depth = parseSwitch(name, value);
    else if (name == "write_previews") options.write_previews = parseSwitch(name, value);
    else if (name == "write_clouds") options.write_clouds = parseSwitch(name, value);
    else if (name == "write_confidence") options.write_confidence = parseSwitch(name, value);
    else if (setFusionOption(name, value, &pipeline.mapper)) continue;
    else if (name == "backend") pipeline.backend = parseBackend(value);
    else if (name == "max_image_size") options.max_image_size = parseValue<int>(name, value);
    else if (name == "num_sources") pipeline.mapper.sources.max_sources = parseValue<int>(name, value);
    else if (name == "scene_depth") pipeline.mapper.sources.default_scene_depth = parseValue<double>(name, value);
    else if (name == "min_triangulation_angle_deg")
      pipeline.mapper.sources.min_triangulation_angle_deg = parseValue<double>(name, value);
    else if (name == "preferred_angle_deg") pipeline.mapper.sources.preferred_angle_deg = parseValue<double>(name, value);
    else if (name == "voxel_size") pipeline.mapper.map.leaf_size = parseValue<double>(name, value);
    else if (name == "min_points_per_voxel") pipeline.mapper.map.min_points_per_voxel = parseValue<int>(name, value);
    else if (name == "queue_size") options.queue_size = parseValue<size_t>(name, value);
    else if (name == "skip_to_newest") pipeline.skip_to_newest = parseSwitch(name, value);
    else if (name == "start_from_neighbours") neighbours.start_from_neighbours = parseSwitch(name, value);
    else if (name == "start_iterations") neighbours.start_iterations = parseValue<int>(name, value);
    else if (name == "start_max_cost") neighbours.start_max_cost = parseValue<double>(name, value);
    else if (name == "geometric_refinement") neighbours.geometric_refinement = parseSwitch(name, value);
    else if (name == "geometric_refinement_iterations") neighbours.geometric_iterations = parseValue<int>(name, value);
    else if (name == "start") frames.start = parseValue<size_t>(name, value);
    else if (name == "count") frames.count = parseValue<size_t>(name, value);
    else if (name == "stride") frames.stride = parseValue<size_t>(name, value);
    else if (name == "keyframe_min_translation") frames.picking.min_translation_m = parseValue<double>(name, value);
    else if (name == "keyframe_min_rotation_deg") frames.picking.min_rotation_deg = parseValue<double>(name, value);
    else if (name == "keyframe_min_turning_translation")
      frames.picking.min_turning_translation_fraction = parseValue<double>(name, value);
    else if (name == "keyframe_min_relative_sharpness")
      frames.picking.min_relative_sharpness = parseValue<double>(name, value);
    else if (name == "realtime") options.realtime_rate = parseValue<double>(name, value);
    else if (name == "depth_min") options.depth_min = parseValue<double>(name, value);
    else if (name == "depth_max") options.depth_max = parseValue<double>(name, value);
    else if (name == "intrinsics") sequence.color_intrinsics = parseIntrinsics(value);
    else if (name == "color_offset") sequence.color_offset = parseVector(name, value);
    else if (name == "frame_rate") sequence.seven_scenes_frame_rate_hz = parseValue<double>(name, value);
    else if (name == "max_time_difference") sequence.tum_max_time_difference_s = parseValue<double>(name, value);
    else if (name == "depth_factor") sequence.tum_depth_units_per_metre = parseValue<double>(name, value);
    else if (name == "frame_period") sequence.frame_period_s = parseValue<double>(name, value);
    else if (name == "pose_refinement") pose_refinement_asked = pipeline.mapper.pose_refinement.enabled =
        parseSwitch(name, value);
    else if (name.rfind(kPoseRefinementPrefix, 0) == 0 &&
             setOptionFromTable(poseRefinementOptionTable(), name.substr(kPoseRefinementPrefix.size()), value,
                                &pipeline.mapper.pose_refinement)) {
      pose_refinement_asked |= pipeline.mapper.pose_refinement.enabled;
    }
    else if (!setPatchMatchOption(name, value, &pipeline.estimator))
      throw InputError("unknown option --" + name + " (see --help)");
  }
  std::string problems = pipeline.mapper.validate() + pipeline.estimator.validate() + sequence.validate();
  auto require = [&problems](bool ok, const std::string& what) {
    if (!ok) problems += what + "\n";
  };
  require(options.max_image_size >= 0, "max_image_size must be >= 0");
  require(!pose_refinement_asked || PoseRefiner::available(),
          std::string("--pose_refinement: ") + PoseRefiner::unavailableMessage());
  require(frames.stride >= 1, "stride must be >= 1");
  std::ostringstream picking;
  appendProblems("keyframe picking", frames.picking.validate(), &picking);
  problems += picking.str();
  require(options.realtime_rate >= 0 && std::isfinite(options.realtime_rate), "realtime must be >= 0");
  require((options.depth_min == 0 && options.depth_max == 0) ||
              (options.depth_min > 0 && options.depth_max > options.depth_min && std::isfinite(options.depth_max)),
          "depth_min and depth_max: both unset, or 0 < depth_min < depth_max");
  if (!problems.empty()) throw InputError("invalid options:\n" + problems);
  return options;
}

size_t resolvedQueueSize(const MapToolOptions& options, size_t keyframes) {
  if (options.queue_size > 0) return options.queue_size;
  return options.realtime_rate > 0 ? PipelineOptions().queue_size : std::max<size_t>(1, keyframes);
}

std::string mapToolUsage() {
  std::ostringstream out;
  out << "Usage: amhmvs_map SEQUENCE_DIR OUTPUT_DIR [options]\n\n"
         "Runs the online mapping pipeline (keyframe store, source selection, AMHMVS depth maps,\n"
         "fusion, voxel map) on a recorded posed sequence, without ROS. SEQUENCE_DIR is one of\n"
         "(detected from its files):\n"
         "  MVSNet dense folder   images/, cams/NNNNNNNN_cam.txt[, pair.txt][, depth_gt/*.pfm]\n"
         "  COLMAP workspace      sparse/[0/] (text or .bin, PINHOLE cameras), images/\n"
         "  7-Scenes / tsdf-fusion frame-NNNNNN.color.jpg|png, .pose.txt (camera-to-world of the\n"
         "                        depth camera), .depth.png (uint16 mm), camera-intrinsics.txt;\n"
         "                        .color.ppm|pgm and 16-bit .depth.pgm for builds without OpenCV\n"
         "  TUM RGB-D             rgb.txt, depth.txt, groundtruth.txt (associated by stamp)\n"
         "Ground-truth depth, where the recording has it, is only used for the report.\n\n"
         "Writes OUTPUT_DIR/: depth/NNNNNN.pfm (z-depth in metres at the processed resolution,\n"
         "NaN invalid or below --confidence_level; written when the keyframe is fused, again when\n"
         "a refinement is), clouds/NNNNNN.ply (each keyframe's fused points, world frame, at the\n"
         "tracker's pose), previews/NNNNNN.png (colour-mapped depth, with --write_previews),\n"
         "map.ply (the voxel map), keyframe_poses.txt (where the map placed each keyframe: TUM\n"
         "format, 'stamp tx ty tz qx qy qz qw', camera-to-world), keyframes.csv and keyframes.jsonl (one row per result: new, late or refined\n"
         "depth map; sources, depth range, stage times in ms, accuracy vs ground truth) and\n"
         "summary.json. Files are written by a writer thread, off the pipeline's path.\n\n"
         "Frames and keyframes:\n"
         "  --start N --count N --stride N   frames looked at (default: all, stride 1)\n"
         "  --keyframe_min_translation M     a keyframe after this much motion (default 0.05 m)\n"
         "  --keyframe_min_rotation_deg D    ... or this much rotation (default 5; both 0: all);\n"
         "                                   motion in the poses' unit (a COLMAP model's is arbitrary)\n"
         "  --keyframe_min_turning_translation F  a frame that only turned, moving less than\n"
         "                                   F x keyframe_min_translation, is a pure rotation: not a\n"
         "                                   keyframe (default 0.5; 0: off)\n"
         "  --keyframe_min_relative_sharpness S   a candidate blurrier than S x the median sharpness\n"
         "                                   of the recent candidates is skipped, the next frame tried\n"
         "                                   (default 0.8; 0: off; 4 in a row: taken anyway)\n"
         "  --realtime RATE                  feed frames at RATE x the recording's rate from\n"
         "                                   another thread; a full queue drops the oldest\n"
         "                                   (default: offline, every keyframe waits)\n"
         "Layout options:\n"
         "  --intrinsics K       colour intrinsics (7-Scenes, TUM): freiburg1|freiburg2|freiburg3|\n"
         "                       ros|fitted7scenes|fx,fy,cx,cy. Default: 7-Scenes uses\n"
         "                       camera-intrinsics.txt (colour taken as registered to depth);\n"
         "                       TUM the freiburgN named by the folder, else ros (525/525/319.5/239.5)\n"
         "  --color_offset X,Y,Z 7-Scenes: colour camera centre in the depth camera frame, metres\n"
         "                       (default 0,0,0). For ../shared/data/redkitchen_7scenes use\n"
         "                       --intrinsics fitted7scenes --color_offset -0.010,0,0\n"
         "  --frame_rate HZ      7-Scenes: stamp = frame number / HZ (default 30)\n"
         "  --max_time_difference S  TUM: association tolerance (default 0.02 s)\n"
         "  --depth_factor F     TUM: depth units per metre (default 5000)\n"
         "  --frame_period S     MVSNet, COLMAP: seconds between frames (default 1)\n"
         "Pipeline options:\n"
         "  --backend auto|cuda|cpu   (default auto)\n"
         "  --max_image_size N   longest processed image side, 0 = as recorded (default 0)\n"
         "  --num_sources N      source views per keyframe, at most (default 8)\n"
         "  --scene_depth M      last-resort scene depth for source selection, when neither the\n"
         "                       data (range, depth maps, matched patches) gives one (default 3)\n"
         "  --min_triangulation_angle_deg D --preferred_angle_deg D  source ranking (default\n"
         "                       1, 5: MVSNet's; 2, 8 suit noisy real poses better, see README)\n"
         "  --depth_min M --depth_max M  depth range of every keyframe (default: from the\n"
         "                       layout (MVSNet, COLMAP), else the neighbours' depth maps)\n"
         "  --voxel_size M       map voxel edge (default 0.02)\n"
         "  --min_points_per_voxel N  map.ply leaves out voxels with fewer points (default 1: none;\n"
         "                       the README's curve: accuracy against completeness)\n"
         "  --fusion_max_reprojection_error PX  --fusion_max_relative_depth_difference F\n"
         "  --fusion_max_normal_angle_deg D  --fusion_max_cost C  --fusion_min_consistent_views N\n"
         "                       the fusion's checks (mapping/fusion.h; 0 = off; defaults 2, 0.02,\n"
         "                       10, off, 2: online_mapper.h's onlineFusionOptions)\n"
         "  --confidence[=0|1]   a calibrated per-pixel confidence from the agreement with the\n"
         "                       other keyframes' depth maps, computed when a keyframe is fused;\n"
         "                       its depth is written then, masked (default 1; 0: every depth map\n"
         "                       written unmasked when estimated)\n"
         "  --confidence_level P written depth: NaN where the confidence (the probability of\n"
         "                       being within 5 %) is below P (default 0.97; 0: nothing masked)\n"
         "  --confidence_again_with_more_views[=0|1]  fuse and write a keyframe again when more\n"
         "                       views see it than when it was fused, up to the 4 the confidence\n"
         "                       counts (the first keyframes of a run; idle work during the next\n"
         "                       8 depth maps; default 1; with --confidence=0 too: its cloud\n"
         "                       is written again, not its depth)\n"
         "  --fuse_neighbours_again[=0|1]  fuse a keyframe again when a refinement replaced the\n"
         "                       depth map of one of its consistency views (idle work; default 0)\n"
         "  --rolling_shutter_s S  the camera's rolling-shutter readout, first to last row:\n"
         "                       each keyframe image is rectified for the rotation during it\n"
         "                       (angular velocity from the poses of the keyframe before it,\n"
         "                       at most --rolling_shutter_max_interval_s before, default 1;\n"
         "                       stamps: --frame_period) (default 0: global shutter)\n"
         "  --rolling_shutter_velocity[=0|1]  use the tracker's velocities where the recording\n"
         "                       has them (MVSNet velocities.txt): their turn rate for the\n"
         "                       rectification and, with --rolling_shutter_translation (default\n"
         "                       1), each row's camera centre in the matching cost and the\n"
         "                       keyframe bundle adjustment (default 0)\n"
         "  --rolling_shutter_from_adjusted_poses[=0|1]  with the keyframe bundle adjustment,\n"
         "                       rectify each keyframe again with the turn rate of the adjusted\n"
         "                       poses before and after it, and estimate its readers again\n"
         "                       (default "
      << (RollingShutterOptions().from_adjusted_poses ? 1 : 0) << ")\n"
         "  --rolling_shutter_velocity_sigma_rad_s W, --rolling_shutter_velocity_sigma_m_s V\n"
         "                       the tracker's velocity noise; both > 0 (with the velocity, its\n"
         "                       translation and the keyframe bundle adjustment): the adjustment\n"
         "                       solves each keyframe's velocity too (default 0, 0: as it comes)\n"
         "  --queue_size N       keyframes waiting (default: all offline, 4 with --realtime)\n"
         "  --skip_to_newest[=0|1]  after a queue overflow take the newest keyframe (default 1)\n"
         "Pose refinement (before stereo; depth, clouds and map stay in the tracker's frame):\n"
         "  --pose_refinement[=0|1]  refine each keyframe's poses relative to its sources (default "
      << (PoseRefinementOptions().enabled ? 1 : 0) << ";\n"
         "                       this build: "
      << (PoseRefiner::available() ? "available" : PoseRefiner::unavailableMessage()) << ")\n";
  for (const PoseRefinementOptionInfo& option : poseRefinementOptionTable()) {
    if (option.name == "enabled") continue;
    out << "  --" << kPoseRefinementPrefix << option.name << " (" << option.get(PoseRefinementOptions()) << ")  "
        << option.help << "\n";
  }
  out << "Neighbours' depth maps (mapping/neighbour_depth.h; off by default):\n"
         "  --start_from_neighbours[=0|1]  a keyframe starts from its sources' depth maps\n"
         "                       reprojected into it (random planes where nothing lands)\n"
         "  --start_iterations N  iterations from that start: 0 = the full schedule (default),\n"
         "                       N = N of local refinement\n"
         "  --start_max_cost C   only source pixels with a matching cost <= C (default 0.5)\n"
         "  --geometric_refinement[=0|1]  a refinement adds the geometric-consistency term\n"
         "                       against its sources' depth maps, from its own depth map\n"
         "  --geometric_refinement_iterations N  its iterations of local refinement (default 3)\n"
         "Outputs:\n"
         "  --write_depth[=0|1] (default 1)  --write_clouds[=0|1] (default 1)\n"
         "  --write_previews[=0|1] (default 0)  --quiet (only warnings and the summary line)\n"
         "  --write_confidence[=0|1] (default 0) confidence/NNNNNN.pfm, each keyframe's confidence\n"
         "                       (probability in [0, 1]) when it is fused (with --confidence)\n\n"
         "Method options (defaults are the paper's):\n"
      << describe(PatchMatchOptions());
  return out.str();
}

}  // namespace amhmvs
