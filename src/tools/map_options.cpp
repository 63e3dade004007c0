#include "map_options.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "tool_options.h"

namespace amhmvs {

namespace {

// The switches of the command line: the tool's own and every true/false
// parameter, by its name and its older flag.
std::set<std::string> commandLineSwitches() {
  std::set<std::string> switches = {"quiet", "write_depth", "write_previews", "write_clouds", "write_confidence"};
  for (const MappingParameter& parameter : mappingParameterTable()) {
    if (!parameter.is_switch) continue;
    switches.insert(parameter.name);
    if (!parameter.alias.empty()) switches.insert(parameter.alias);
  }
  return switches;
}

// A mapping parameter given as --group/name, --group.name or its older flag;
// false when `name` is none of them.
bool setParameterFlag(const std::string& name, const std::string& value, MappingParameters* parameters,
                      std::string* canonical) {
  std::string slashed = name;
  std::replace(slashed.begin(), slashed.end(), '.', '/');
  const MappingParameter* parameter = findMappingParameter(slashed);
  if (!parameter) parameter = findMappingParameterByAlias(name);
  if (!parameter) return false;
  if (isNodeParameter(*parameter)) throw InputError("option --" + name + ": a parameter of the ROS node only");
  try {
    parameter->set(*parameters, value);
  } catch (const InputError& e) {
    throw InputError("option --" + name + ": " + e.what());
  }
  *canonical = parameter->name;
  return true;
}

}  // namespace

MapToolOptions parseMapToolArguments(const std::vector<std::string>& arguments) {
  MapToolOptions options;
  MappingParameters parameters;
  FrameSelection& frames = options.frames;
  PosedSequenceOptions& sequence = options.sequence;
  std::set<std::string> given;  // parameters set by flags, --set or --config
  const std::set<std::string> switches = commandLineSwitches();
  for (size_t i = 0; i < arguments.size(); ++i) {
    std::string name, value, canonical;
    nextOption(arguments, &i, switches, &name, &value);
    if (name == "quiet") options.quiet = parseSwitch(name, value);
    else if (name == "write_depth") options.write_depth = parseSwitch(name, value);
    else if (name == "write_previews") options.write_previews = parseSwitch(name, value);
    else if (name == "write_clouds") options.write_clouds = parseSwitch(name, value);
    else if (name == "write_confidence") options.write_confidence = parseSwitch(name, value);
    else if (name == "config") {
      for (const std::string& set : applyParameterFile(value, &parameters)) given.insert(set);
    } else if (name == "set") {
      const size_t eq = value.find('=');
      if (eq == std::string::npos) throw InputError("option --set: expected group/name=value, got '" + value + "'");
      setMappingParameter(value.substr(0, eq), value.substr(eq + 1), &parameters);
      given.insert(value.substr(0, eq));
    } else if (setParameterFlag(name, value, &parameters, &canonical)) given.insert(canonical);
    else if (name == "start") frames.start = parseValue<size_t>(name, value);
    else if (name == "count") frames.count = parseValue<size_t>(name, value);
    else if (name == "stride") frames.stride = parseValue<size_t>(name, value);
    else if (name == "realtime") options.realtime_rate = parseValue<double>(name, value);
    else if (name == "depth_min") options.depth_min = parseValue<double>(name, value);
    else if (name == "depth_max") options.depth_max = parseValue<double>(name, value);
    else if (name == "intrinsics") sequence.color_intrinsics = parseIntrinsics(value);
    else if (name == "color_offset") sequence.color_offset = parseVector3(name, value);
    else if (name == "frame_rate") sequence.seven_scenes_frame_rate_hz = parseValue<double>(name, value);
    else if (name == "max_time_difference") sequence.tum_max_time_difference_s = parseValue<double>(name, value);
    else if (name == "depth_factor") sequence.tum_depth_units_per_metre = parseValue<double>(name, value);
    else if (name == "frame_period") sequence.frame_period_s = parseValue<double>(name, value);
    else if (name == "trajectory") sequence.trajectory_path = value;
    else
      throw InputError("unknown option --" + name + " (did you mean --" + closestParameterName(name) +
                       "? see --help)");
  }
  options.pipeline = parameters.pipeline;
  frames.picking = parameters.keyframes;
  options.max_image_size = parameters.max_image_size;
  options.queue_size = given.count("queue_size") ? parameters.pipeline.queue_size : 0;
  const bool pose_refinement_asked = parameters.pipeline.mapper.pose_refinement.enabled;
  std::string problems = parameters.validate() + sequence.validate();
  auto require = [&problems](bool ok, const std::string& what) {
    if (!ok) problems += what + "\n";
  };
  require(!pose_refinement_asked || PoseRefiner::available(),
          std::string("--pose_refinement: ") + PoseRefiner::unavailableMessage());
  require(frames.stride >= 1, "stride must be >= 1");
  require(options.realtime_rate >= 0 && std::isfinite(options.realtime_rate), "realtime must be >= 0");
  require((options.depth_min == 0 && options.depth_max == 0) ||
              (options.depth_min > 0 && options.depth_max > options.depth_min && std::isfinite(options.depth_max)),
          "depth_min and depth_max: both unset, or 0 < depth_min < depth_max");
  if (!problems.empty()) throw InputError("invalid options:\n" + problems);
  return options;
}

size_t resolvedQueueSize(const MapToolOptions& options, size_t keyframes) {
  if (options.queue_size > 0) return options.queue_size;
  return options.realtime_rate > 0 ? MappingParameters().pipeline.queue_size : std::max<size_t>(1, keyframes);
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
         "map.ply (the voxel map), mesh.ply (the surface mesh, with surface/enabled), keyframe_poses.txt (where the map placed each keyframe: TUM\n"
         "format, 'stamp tx ty tz qx qy qz qw', camera-to-world), keyframes.csv and keyframes.jsonl (one row per result: new, late or refined\n"
         "depth map; sources, depth range, stage times in ms, accuracy vs ground truth) and\n"
         "summary.json. Files are written by a writer thread, off the pipeline's path.\n"
         "Ctrl-C or SIGTERM: reads no more frames, finishes the keyframes in the pipeline, writes\n"
         "the outputs (summary.json says \"interrupted_by\") and exits 130 / 143.\n\n"
         "Parameters: every parameter of the mapping nodelet, with the same names and defaults\n"
         "(docs/parameters.md; the nodelet's config/mapping.yaml lists them all):\n"
         "  --config FILE        read a parameter file in the layout of config/mapping.yaml\n"
         "  --set group/name=VALUE  one parameter (e.g. --set sources/max_sources=8)\n"
         "  --group/name VALUE   the same (--group.name too); the older flags listed below work\n"
         "  --print_parameters yaml|markdown  print config/mapping.yaml or docs/parameters.md\n"
         "Given in order: a later setting wins.\n\n"
         "Frames:\n"
         "  --start N --count N --stride N   frames looked at (default: all, stride 1); keyframes\n"
         "                                   among them by keyframe_* (motion in the poses' unit)\n"
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
         "  --trajectory FILE    a tracker's poses (TUM format, e.g. amhmvs_odometry's) instead of\n"
         "                       the sequence's, matched by stamp; the sequence's are the truth\n"
         "                       of the reports\n"
         "  --depth_min M --depth_max M  depth range of every keyframe (default: from the\n"
         "                       layout (MVSNet, COLMAP), else the neighbours' depth maps)\n"
         "Outputs:\n"
         "  --write_depth[=0|1] (default 1)  --write_clouds[=0|1] (default 1)\n"
         "  --write_previews[=0|1] (default 0)  --quiet (only warnings and the summary line)\n"
         "  --write_confidence[=0|1] (default 0) confidence/NNNNNN.pfm, each keyframe's confidence\n"
         "                       (probability in [0, 1]) when it is fused (with --confidence)\n\n"
         "Mapping parameters (name, default, meaning; the older flag in brackets):\n";
  const MappingParameters defaults;
  for (const MappingParameter& parameter : mappingParameterTable()) {
    if (isNodeParameter(parameter)) continue;  // the ROS node's own (input, frames, publication)
    out << "  --" << parameter.name << " (" << parameter.get(defaults) << ")"
        << (parameter.alias.empty() ? "" : " [--" + parameter.alias + "]") << "  " << parameter.help << "\n";
  }
  out << "This build's pose refinement: "
      << (PoseRefiner::available() ? "available" : PoseRefiner::unavailableMessage()) << "\n";
  return out.str();
}

}  // namespace amhmvs
