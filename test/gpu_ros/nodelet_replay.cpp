// Runs amhmvs_mapping/MappingNodelet itself (loaded through pluginlib by
// nodelet::Loader, as amhmvs_mapping_node does) on a recorded bag, in one
// process with its own ROS master (mini_master.h), and checks its outputs as
// test/ros/check_outputs.py does for replay_fountain.test: every keyframe gets
// a REP-118 depth image (32FC1, NaN invalid) with its stamp and optical frame,
// camera_info, confidence and preview; keyframe clouds and the map are finite;
// the diagnostics name the backend asked for; the depth images and the map
// agree with the fountain's sparse points.
//
// Made for the GPU machine, which has no ROS and no Python ROS: everything it
// needs is staged by scripts/gpu_machine/stage_ros_gpu.sh. Usage:
//   nodelet_replay --bag B [--config replay_fountain.yaml] [--backend cuda]
//                  [--max-image-size 256] [--iterations 3] [--rate 1]
//                  [--timeout 300] [--sparse-points F] [--report out.txt]
//                  [--expected-frames 11] [--depth-floors a,b,c]
//                  [--map-floors a,b,c] [--min-map-coverage 85]
//                  [--stage DIR: report the libraries loaded from outside DIR]
// Exit status 0 when every check passes.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdarg>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <nodelet/loader.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include "mini_master.h"

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Args {
  std::string bag, config, sparse_points, report, stage;
  std::string backend = "cuda";
  int max_image_size = 256, iterations = 3, expected_frames = 11;
  double rate = 1.0, timeout = 300.0, min_depth = 3.0, max_depth = 50.0, min_map_coverage = 0.0;
  std::vector<double> depth_floors = {0, 0, 0}, map_floors = {0, 0, 0};
};

std::vector<double> parseList(const std::string& text) {
  std::vector<double> values;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) values.push_back(std::atof(item.c_str()));
  return values;
}

// ---- a YAML subset: nested maps of scalars and [a, b] lists, # comments ----
XmlRpc::XmlRpcValue scalar(std::string text) {
  if (text.size() >= 2 && (text[0] == '"' || text[0] == '\'')) return XmlRpc::XmlRpcValue(text.substr(1, text.size() - 2));
  if (text == "true" || text == "True") return XmlRpc::XmlRpcValue(true);
  if (text == "false" || text == "False") return XmlRpc::XmlRpcValue(false);
  char* end = nullptr;
  const long i = std::strtol(text.c_str(), &end, 10);
  if (*end == '\0' && !text.empty()) return XmlRpc::XmlRpcValue(static_cast<int>(i));
  const double d = std::strtod(text.c_str(), &end);
  if (*end == '\0' && !text.empty()) return XmlRpc::XmlRpcValue(d);
  return XmlRpc::XmlRpcValue(text);
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// key -> value of every leaf, keys joined with '/'.
bool readYaml(const std::string& path, std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>>* leaves) {
  std::ifstream in(path);
  if (!in) return false;
  std::vector<std::pair<int, std::string>> stack;  // (indent, key) of open maps
  std::string line;
  while (std::getline(in, line)) {
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line = line.substr(0, hash);
    if (trim(line).empty()) continue;
    const int indent = static_cast<int>(line.find_first_not_of(' '));
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = trim(line.substr(indent, colon - indent)), value = trim(line.substr(colon + 1));
    while (!stack.empty() && stack.back().first >= indent) stack.pop_back();
    std::string prefix;
    for (const auto& s : stack) prefix += s.second + "/";
    if (value.empty()) {
      stack.push_back({indent, key});
    } else if (value[0] == '[') {
      XmlRpc::XmlRpcValue list;
      list.setSize(0);
      std::stringstream ss(value.substr(1, value.find(']') - 1));
      std::string item;
      int i = 0;
      while (std::getline(ss, item, ',')) list[i++] = scalar(trim(item));
      leaves->push_back({prefix + key, list});
    } else {
      leaves->push_back({prefix + key, scalar(value)});
    }
  }
  return true;
}

// ---- what the nodelet publishes ----
template <class M>
struct Received {
  typename M::ConstPtr msg;
  Clock::time_point at;
};

struct Recorder {
  std::mutex mutex;
  std::vector<Received<sensor_msgs::Image>> depth, confidence, preview;
  std::vector<Received<sensor_msgs::CameraInfo>> info;
  std::vector<Received<sensor_msgs::PointCloud2>> clouds, maps;
  std::map<std::string, std::string> diagnostics;  // of "depth estimation"
  int diagnostics_messages = 0;

  template <class M>
  boost::function<void(const typename M::ConstPtr&)> into(std::vector<Received<M>>* store) {
    return [this, store](const typename M::ConstPtr& msg) {
      std::lock_guard<std::mutex> lock(mutex);
      store->push_back({msg, Clock::now()});
    };
  }
  void onDiagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    for (const auto& status : msg->status) {
      if (status.name.find("depth estimation") == std::string::npos) continue;
      std::lock_guard<std::mutex> lock(mutex);
      diagnostics.clear();
      for (const auto& kv : status.values) diagnostics[kv.key] = kv.value;
      ++diagnostics_messages;
    }
  }
  std::string diag(const std::string& key, const std::string& otherwise = "") {
    const auto it = diagnostics.find(key);
    return it == diagnostics.end() ? otherwise : it->second;
  }
};

// ---- checks ----
struct Report {
  std::ostringstream text;
  int failed = 0, passed = 0;
  void line(const std::string& s) {
    text << s << "\n";
    std::printf("%s\n", s.c_str());
    std::fflush(stdout);
  }
  void check(bool ok, const std::string& name, const std::string& detail) {
    (ok ? passed : failed)++;
    line(std::string(ok ? "PASS " : "FAIL ") + name + ": " + detail);
  }
};

std::string fmt(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char* format, ...) {
  char buffer[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof(buffer), format, args);
  va_end(args);
  return buffer;
}

const float* floats(const sensor_msgs::Image& m) { return reinterpret_cast<const float*>(m.data.data()); }

// Points of a PointCloud2 with float32 fields x y z rgb normal_x normal_y
// normal_z; false if the layout differs.
bool cloudPoints(const sensor_msgs::PointCloud2& m, std::vector<std::array<float, 7>>* points) {
  static const char* names[7] = {"x", "y", "z", "rgb", "normal_x", "normal_y", "normal_z"};
  if (m.fields.size() != 7) return false;
  int offsets[7];
  for (int i = 0; i < 7; ++i) {
    if (m.fields[i].name != names[i] || m.fields[i].datatype != sensor_msgs::PointField::FLOAT32) return false;
    offsets[i] = m.fields[i].offset;
  }
  const size_t n = static_cast<size_t>(m.width) * m.height;
  if (m.data.size() < n * m.point_step || m.is_bigendian) return false;
  points->resize(n);
  for (size_t p = 0; p < n; ++p) {
    const uint8_t* base = m.data.data() + (p / m.width) * m.row_step + (p % m.width) * m.point_step;
    for (int i = 0; i < 7; ++i) std::memcpy(&(*points)[p][i], base + offsets[i], 4);
  }
  return true;
}

// The fountain's sparse points (sparse_agreement.py).
struct SparsePoint {
  double x, y, z;
  std::set<int> views;
};

std::vector<SparsePoint> readSparsePoints(const std::string& path) {
  std::vector<SparsePoint> points;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    SparsePoint p;
    int count = 0;
    if (!(ss >> p.x >> p.y >> p.z >> count)) continue;
    for (int i = 0, v; i < count && ss >> v; ++i) p.views.insert(v);
    points.push_back(p);
  }
  return points;
}

struct Camera {
  double fx, fy, cx, cy, R[3][3], C[3];
  int width, height;
  Camera(const sensor_msgs::CameraInfo& info, const geometry_msgs::Pose& pose) {
    fx = info.K[0], cx = info.K[2], fy = info.K[4], cy = info.K[5];
    width = info.width, height = info.height;
    const double x = pose.orientation.x, y = pose.orientation.y, z = pose.orientation.z, w = pose.orientation.w;
    const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    std::memcpy(R, r, sizeof(R));
    C[0] = pose.position.x, C[1] = pose.position.y, C[2] = pose.position.z;
  }
  // Nearest pixel and z-depth of a world point.
  bool pixel(double px, double py, double pz, int* u, int* v, double* depth) const {
    const double d[3] = {px - C[0], py - C[1], pz - C[2]};
    double c[3];
    for (int k = 0; k < 3; ++k) c[k] = R[0][k] * d[0] + R[1][k] * d[1] + R[2][k] * d[2];
    if (c[2] <= 0) return false;
    *u = static_cast<int>(std::lround(fx * c[0] / c[2] + cx));
    *v = static_cast<int>(std::lround(fy * c[1] / c[2] + cy));
    *depth = c[2];
    return *u >= 0 && *u < width && *v >= 0 && *v < height;
  }
};

struct Agreement {
  long total = 0, finite = 0, within[3] = {0, 0, 0};
  void add(double measured, double truth) {
    ++total;
    if (!std::isfinite(measured)) return;
    ++finite;
    const double error = std::fabs(measured - truth) / truth;
    const double thresholds[3] = {0.01, 0.02, 0.05};
    for (int i = 0; i < 3; ++i) within[i] += error < thresholds[i];
  }
};

// Observations of the points by view `view`, against depth_at(u, v).
template <class DepthAt>
void agreement(const std::vector<SparsePoint>& points, const Camera& camera, int view, DepthAt depth_at,
               Agreement* a) {
  for (const SparsePoint& p : points) {
    if (!p.views.count(view)) continue;
    int u, v;
    double z;
    if (!camera.pixel(p.x, p.y, p.z, &u, &v, &z)) continue;
    a->add(depth_at(u, v), z);
  }
}

bool parseArgs(int argc, char** argv, Args* a) {
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) return false;
    const std::string v = argv[++i];
    if (k == "--bag") a->bag = v;
    else if (k == "--config") a->config = v;
    else if (k == "--sparse-points") a->sparse_points = v;
    else if (k == "--report") a->report = v;
    else if (k == "--stage") a->stage = v;
    else if (k == "--backend") a->backend = v;
    else if (k == "--max-image-size") a->max_image_size = std::atoi(v.c_str());
    else if (k == "--iterations") a->iterations = std::atoi(v.c_str());
    else if (k == "--expected-frames") a->expected_frames = std::atoi(v.c_str());
    else if (k == "--rate") a->rate = std::atof(v.c_str());
    else if (k == "--timeout") a->timeout = std::atof(v.c_str());
    else if (k == "--min-depth") a->min_depth = std::atof(v.c_str());
    else if (k == "--max-depth") a->max_depth = std::atof(v.c_str());
    else if (k == "--depth-floors") a->depth_floors = parseList(v);
    else if (k == "--map-floors") a->map_floors = parseList(v);
    else if (k == "--min-map-coverage") a->min_map_coverage = std::atof(v.c_str());
    else return false;
  }
  return !a->bag.empty() && a->depth_floors.size() == 3 && a->map_floors.size() == 3;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parseArgs(argc, argv, &args)) {
    std::fprintf(stderr, "usage: %s --bag B [--config Y] [--backend cuda|cpu|auto] ... (see the source)\n", argv[0]);
    return 2;
  }
  Report report;
  const Clock::time_point start = Clock::now();

  // The master and the parameters of replay_fountain.test (mapping.launch
  // with test/ros/replay_fountain.yaml), the backend from the command line.
  gpu_ros::MiniMaster master;
  if (!master.start(21311 + static_cast<int>(getpid() % 20000))) {
    std::fprintf(stderr, "could not bind the master's port\n");
    return 2;
  }
  const std::string node = "/amhmvs/mapping";
  if (!args.config.empty()) {
    std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>> leaves;
    if (!readYaml(args.config, &leaves)) {
      std::fprintf(stderr, "cannot read %s\n", args.config.c_str());
      return 2;
    }
    for (const auto& leaf : leaves) master.setParam(node + "/" + leaf.first, leaf.second);
  }
  master.setParam("/use_sim_time", XmlRpc::XmlRpcValue(false));
  master.setParam(node + "/input_mode", XmlRpc::XmlRpcValue(std::string("pose")));
  master.setParam(node + "/fixed_frame", XmlRpc::XmlRpcValue(std::string("world")));
  master.setParam(node + "/backend", XmlRpc::XmlRpcValue(args.backend));
  master.setParam(node + "/max_image_size", XmlRpc::XmlRpcValue(args.max_image_size));
  master.setParam(node + "/estimator/iterations", XmlRpc::XmlRpcValue(args.iterations));

  ros::M_string init_remappings = {{"__master", master.uri()}, {"__ip", "127.0.0.1"}};
  ros::init(init_remappings, "amhmvs_nodelet_replay", ros::init_options::NoSigintHandler);
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  report.line("master " + master.uri() + ", backend asked: " + args.backend + ", bag " + args.bag);

  Recorder rec;
  const std::string ns = "/amhmvs";
  std::vector<ros::Subscriber> subs = {
      nh.subscribe<sensor_msgs::Image>(ns + "/depth/image", 50, rec.into(&rec.depth)),
      nh.subscribe<sensor_msgs::CameraInfo>(ns + "/depth/camera_info", 50, rec.into(&rec.info)),
      nh.subscribe<sensor_msgs::Image>(ns + "/confidence/image", 50, rec.into(&rec.confidence)),
      nh.subscribe<sensor_msgs::Image>(ns + "/depth/preview", 50, rec.into(&rec.preview)),
      nh.subscribe<sensor_msgs::PointCloud2>(ns + "/keyframe_cloud", 50, rec.into(&rec.clouds)),
      nh.subscribe<sensor_msgs::PointCloud2>(ns + "/map", 5, rec.into(&rec.maps)),
      nh.subscribe("/diagnostics", 10, &Recorder::onDiagnostics, &rec)};

  // The bag's topics, published from here.
  ros::Publisher image_pub = nh.advertise<sensor_msgs::Image>("/camera/image_raw", 20);
  ros::Publisher info_pub = nh.advertise<sensor_msgs::CameraInfo>("/camera/camera_info", 20);
  ros::Publisher pose_pub = nh.advertise<geometry_msgs::PoseStamped>("/camera/pose", 20);
  ros::Publisher tf_pub = nh.advertise<tf2_msgs::TFMessage>("/tf", 20);

  // The nodelet, loaded as amhmvs_mapping_node loads it (pluginlib finds it
  // through ROS_PACKAGE_PATH and CMAKE_PREFIX_PATH).
  nodelet::Loader loader(false);
  const nodelet::M_string remappings = {{ns + "/image", "/camera/image_raw"},
                                        {ns + "/camera_info", "/camera/camera_info"},
                                        {ns + "/pose", "/camera/pose"}};
  const Clock::time_point load_start = Clock::now();
  if (!loader.load(node, "amhmvs_mapping/MappingNodelet", remappings, nodelet::V_string())) {
    report.check(false, "load", "nodelet::Loader could not load amhmvs_mapping/MappingNodelet");
    return 1;
  }
  report.line(fmt("nodelet loaded in %.2f s", secondsSince(load_start)));

  // All connected (as rosbag play -d 5 waits in the rostest).
  const Clock::time_point wait_start = Clock::now();
  auto connected = [&] {
    if (image_pub.getNumSubscribers() < 1 || info_pub.getNumSubscribers() < 1 || pose_pub.getNumSubscribers() < 1)
      return false;
    for (const ros::Subscriber& s : subs)
      if (s.getNumPublishers() < 1) return false;
    return true;
  };
  while (!connected() && secondsSince(wait_start) < 30) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  report.check(connected(), "connections", fmt("inputs and outputs connected after %.2f s", secondsSince(wait_start)));

  // Play the bag at its rate (wall clock; stamps as recorded).
  std::map<uint64_t, Clock::time_point> image_published;  // stamp -> wall time
  std::map<uint64_t, geometry_msgs::Pose> poses;
  std::vector<ros::Time> image_stamps;
  {
    rosbag::Bag bag;
    bag.open(args.bag, rosbag::bagmode::Read);
    rosbag::View view(bag);
    const ros::Time bag_start = view.getBeginTime();
    const Clock::time_point play_start = Clock::now();
    for (const rosbag::MessageInstance& m : view) {
      const double at = (m.getTime() - bag_start).toSec() / args.rate;
      std::this_thread::sleep_until(play_start + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(at)));
      if (m.getTopic() == "/camera/image_raw") {
        const auto msg = m.instantiate<sensor_msgs::Image>();
        image_stamps.push_back(msg->header.stamp);
        image_published[msg->header.stamp.toNSec()] = Clock::now();
        image_pub.publish(msg);
      } else if (m.getTopic() == "/camera/camera_info") {
        info_pub.publish(m.instantiate<sensor_msgs::CameraInfo>());
      } else if (m.getTopic() == "/camera/pose") {
        const auto msg = m.instantiate<geometry_msgs::PoseStamped>();
        poses[msg->header.stamp.toNSec()] = msg->pose;
        pose_pub.publish(msg);
      } else if (m.getTopic() == "/tf") {
        tf_pub.publish(m.instantiate<tf2_msgs::TFMessage>());
      }
    }
    report.line(fmt("played %zu images in %.2f s", image_stamps.size(), secondsSince(play_start)));
  }
  std::sort(image_stamps.begin(), image_stamps.end());

  // Until every keyframe has its depth and the pipeline is idle (as
  // check_outputs.py waits), then the map after the last keyframe.
  const Clock::time_point done_start = Clock::now();
  const int expected = args.expected_frames;
  bool done = false;
  while (!done && secondsSince(start) < args.timeout) {
    {
      std::lock_guard<std::mutex> lock(rec.mutex);
      done = static_cast<int>(rec.depth.size()) >= expected && static_cast<int>(rec.info.size()) >= expected &&
             rec.diag("depth_maps") == std::to_string(expected) && rec.diag("idle") == "True" &&
             static_cast<int>(rec.clouds.size()) >= std::atoi(rec.diag("keyframes_fused", "0").c_str());
    }
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  const double processing_s = secondsSince(done_start);
  const Clock::time_point map_deadline = Clock::now() + std::chrono::seconds(10);
  while (Clock::now() < map_deadline) {
    {
      std::lock_guard<std::mutex> lock(rec.mutex);
      ros::Time last;
      for (const auto& d : rec.depth) last = std::max(last, d.msg->header.stamp);
      if (!rec.maps.empty() && rec.maps.back().msg->header.stamp >= last) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  std::this_thread::sleep_for(std::chrono::seconds(3));  // late messages, one more diagnostics update

  // Libraries mapped now (the nodelet and its plugins still loaded).
  std::string libraries;
  if (!args.stage.empty()) {
    // Which shared objects came from outside the staged runtime (the system's
    // libc, libstdc++, CUDA driver are expected).
    std::ifstream maps("/proc/self/maps");
    std::set<std::string> inside, outside;
    std::string line;
    while (std::getline(maps, line)) {
      const size_t slash = line.find('/');
      if (slash == std::string::npos) continue;
      const std::string path = line.substr(slash);
      if (path.find(".so") == std::string::npos) continue;
      (path.compare(0, args.stage.size(), args.stage) == 0 ? inside : outside).insert(path);
    }
    std::string list;
    for (const std::string& p : outside) list += "\n    " + p;
    libraries = (fmt("libraries: %zu from the stage %s, %zu from outside it:", inside.size(), args.stage.c_str(),
                    outside.size()) + list);
  }
  // Stop the nodelet before checking (no more messages).
  loader.clear();
  std::lock_guard<std::mutex> lock(rec.mutex);
  report.line(fmt("done=%d after %.1f s (%.1f s after the last frame); %zu depth, %zu camera_info, %zu confidence, "
                  "%zu preview, %zu keyframe clouds, %zu maps, %d diagnostics messages",
                  done, secondsSince(start), processing_s, rec.depth.size(), rec.info.size(), rec.confidence.size(),
                  rec.preview.size(), rec.clouds.size(), rec.maps.size(), rec.diagnostics_messages));
  std::string diag_line = "diagnostics:";
  for (const auto& kv : rec.diagnostics) diag_line += " {" + kv.first + ": " + kv.second + "}";
  report.line(diag_line);

  report.check(done, "finished", fmt("all keyframes estimated and the pipeline idle within %.0f s", args.timeout));
  report.check(static_cast<int>(image_stamps.size()) == expected, "all_frames_played",
               fmt("%zu of %d", image_stamps.size(), expected));
  report.check(rec.diag("backend") == args.backend || args.backend == "auto", "backend",
               "diagnostics backend \"" + rec.diag("backend") + "\", asked \"" + args.backend + "\"");

  // Depth: every keyframe, its stamp, REP-118.
  std::set<uint64_t> depth_stamps;
  std::map<uint64_t, const sensor_msgs::Image*> latest_depth;
  for (const auto& d : rec.depth) {
    depth_stamps.insert(d.msg->header.stamp.toNSec());
    latest_depth[d.msg->header.stamp.toNSec()] = d.msg.get();
  }
  std::set<uint64_t> image_set;
  for (const ros::Time& t : image_stamps) image_set.insert(t.toNSec());
  report.check(depth_stamps == image_set, "depth_for_every_keyframe",
               fmt("%zu distinct depth stamps, %zu image stamps, %zu depth images (refined again: %s)",
                   depth_stamps.size(), image_set.size(), rec.depth.size(), rec.diag("refined_depth_maps").c_str()));
  report.check(static_cast<long>(rec.depth.size()) - static_cast<long>(image_set.size()) ==
                   std::atol(rec.diag("refined_depth_maps", "0").c_str()),
               "depth_count", "depth images = keyframes + refined_depth_maps");
  std::vector<double> latencies;
  for (const auto& d : rec.depth) {
    const auto it = image_published.find(d.msg->header.stamp.toNSec());
    if (it != image_published.end() && d.at >= it->second)
      latencies.push_back(std::chrono::duration<double>(d.at - it->second).count());
  }
  bool format_ok = !rec.depth.empty(), values_ok = !rec.depth.empty();
  std::string format_detail, values_detail;
  for (const auto& d : rec.depth) {
    const sensor_msgs::Image& m = *d.msg;
    const bool ok = m.encoding == "32FC1" && m.header.frame_id == "camera_optical" &&
                    static_cast<int>(std::max(m.width, m.height)) == args.max_image_size && m.step == 4 * m.width &&
                    m.data.size() == static_cast<size_t>(m.step) * m.height && !m.is_bigendian;
    if (!ok) {
      format_ok = false;
      format_detail += fmt(" [%s %s %ux%u step %u]", m.encoding.c_str(), m.header.frame_id.c_str(), m.width,
                           m.height, m.step);
      continue;
    }
    const size_t n = static_cast<size_t>(m.width) * m.height;
    const float* v = floats(m);
    std::vector<float> finite;
    size_t nan = 0, inf = 0, non_positive = 0, inside = 0;
    for (size_t i = 0; i < n; ++i) {
      if (std::isnan(v[i])) ++nan;
      else if (std::isinf(v[i])) ++inf;
      else {
        finite.push_back(v[i]);
        if (v[i] <= 0) ++non_positive;
        if (v[i] >= args.min_depth && v[i] <= args.max_depth) ++inside;
      }
    }
    double median = std::numeric_limits<double>::quiet_NaN();
    if (!finite.empty()) {
      std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
      median = finite[finite.size() / 2];
    }
    const double fraction = double(finite.size()) / n, inside_fraction = finite.empty() ? 0 : double(inside) / finite.size();
    const bool good = fraction > 0.8 && inf == 0 && non_positive == 0 && inside_fraction > 0.99 && median >= 5.0 &&
                      median <= 18.5;
    values_ok = values_ok && good;
    values_detail += fmt("\n    stamp %.1f: %ux%u, %.1f %% finite, %zu NaN, %zu inf, %zu <= 0, %.2f %% in [%.0f, %.0f] m, "
                         "median %.2f m%s",
                         m.header.stamp.toSec(), m.width, m.height, 100 * fraction, nan, inf, non_positive,
                         100 * inside_fraction, args.min_depth, args.max_depth, median, good ? "" : "  <-- bad");
  }
  report.check(format_ok, "depth_format", "32FC1, frame camera_optical, longer side " +
                                              std::to_string(args.max_image_size) + ", step 4*width" + format_detail);
  report.check(values_ok, "depth_values",
               "REP-118: > 80 % finite, invalid = NaN (no inf, no <= 0), > 99 % in range, median 5..18.5 m" +
                   values_detail);
  if (!latencies.empty()) {
    std::sort(latencies.begin(), latencies.end());
    report.line(fmt("latency image published -> depth received: min %.3f s, median %.3f s, max %.3f s over %zu depth images",
                    latencies.front(), latencies[latencies.size() / 2], latencies.back(), latencies.size()));
  }

  // camera_info per depth image.
  std::map<uint64_t, const sensor_msgs::CameraInfo*> infos;
  for (const auto& i : rec.info) infos[i.msg->header.stamp.toNSec()] = i.msg.get();
  bool info_ok = !rec.depth.empty();
  for (const auto& d : rec.depth) {
    const auto it = infos.find(d.msg->header.stamp.toNSec());
    if (it == infos.end() || it->second->width != d.msg->width || it->second->height != d.msg->height ||
        it->second->header.frame_id != d.msg->header.frame_id ||
        std::fabs(it->second->K[0] - 689.87 * d.msg->width / 768.0) > 1e-3 * 689.87)
      info_ok = false;
  }
  report.check(info_ok, "camera_info_matches_depth", "size, frame and fx (689.87 * scale) of each depth image");

  // Confidence and preview.
  bool confidence_ok = rec.confidence.size() == rec.depth.size();
  for (const auto& c : rec.confidence) {
    if (c.msg->encoding != "32FC1" || c.msg->data.size() != 4ul * c.msg->width * c.msg->height) {
      confidence_ok = false;
      continue;
    }
    const float* v = floats(*c.msg);
    for (size_t i = 0; i < static_cast<size_t>(c.msg->width) * c.msg->height; ++i)
      if (!(v[i] >= 0.0f && v[i] <= 1.0f)) confidence_ok = false;
  }
  bool preview_ok = rec.preview.size() == rec.depth.size();
  for (const auto& p : rec.preview)
    if (p.msg->encoding != "bgr8" || p.msg->data.size() != 3ul * p.msg->width * p.msg->height) preview_ok = false;
  report.check(confidence_ok, "confidence", fmt("%zu images, 32FC1 in [0, 1]", rec.confidence.size()));
  report.check(preview_ok, "preview", fmt("%zu images, bgr8", rec.preview.size()));

  // Keyframe clouds.
  {
    const long fused = std::atol(rec.diag("keyframes_fused", "-1").c_str());
    const long again = std::atol(rec.diag("keyframes_fused_again", "0").c_str());
    std::set<uint64_t> cloud_stamps;
    std::map<uint64_t, size_t> latest_size;
    bool ok = !rec.clouds.empty();
    size_t total_points = 0;
    for (const auto& c : rec.clouds) {
      cloud_stamps.insert(c.msg->header.stamp.toNSec());
      std::vector<std::array<float, 7>> points;
      if (!cloudPoints(*c.msg, &points) || c.msg->header.frame_id != "camera_optical" ||
          !depth_stamps.count(c.msg->header.stamp.toNSec())) {
        ok = false;
        continue;
      }
      for (const auto& p : points)
        for (float v : p)
          if (!std::isfinite(v)) ok = false;
      latest_size[c.msg->header.stamp.toNSec()] = points.size();
      total_points += points.size();
    }
    for (const auto& s : latest_size)
      if (s.second <= 1000) ok = false;
    ok = ok && static_cast<long>(cloud_stamps.size()) == fused &&
         static_cast<long>(rec.clouds.size()) == fused + again;
    report.check(ok, "keyframe_clouds",
                 fmt("%zu clouds of %zu keyframes (fused %ld, again %ld), %zu points in all, all finite, "
                     "frame camera_optical, > 1000 points each",
                     rec.clouds.size(), cloud_stamps.size(), fused, again, total_points));
  }

  // Diagnostics counts (as test_08).
  {
    bool dropped = false;
    for (const auto& kv : rec.diagnostics)
      if (kv.first.compare(0, 7, "dropped") == 0 && kv.second != "0") dropped = true;
    const bool ok = rec.diag("keyframes_received") == std::to_string(expected) &&
                    rec.diag("depth_maps") == std::to_string(expected) && !dropped &&
                    std::atol(rec.diag("map voxels", "0").c_str()) > 0;
    report.check(ok, "diagnostics_counts",
                 "keyframes_received " + rec.diag("keyframes_received") + ", depth_maps " + rec.diag("depth_maps") +
                     ", keyframes_without_sources " + rec.diag("keyframes_without_sources") + ", late_depth_maps " +
                     rec.diag("late_depth_maps") + ", map voxels " + rec.diag("map voxels") +
                     (dropped ? ", inputs dropped" : ", nothing dropped"));
  }

  // The map.
  std::vector<std::array<float, 7>> map_points;
  {
    bool ok = !rec.maps.empty() && rec.maps.back().msg->header.frame_id == "world" &&
              cloudPoints(*rec.maps.back().msg, &map_points) && map_points.size() > 1000;
    size_t non_finite = 0;
    for (const auto& p : map_points)
      for (float v : p)
        if (!std::isfinite(v)) ++non_finite;
    report.check(ok && non_finite == 0, "map",
                 fmt("%zu maps received, the last: %zu points, %zu non-finite values, frame %s", rec.maps.size(),
                     map_points.size(), non_finite, rec.maps.empty() ? "-" : rec.maps.back().msg->header.frame_id.c_str()));
  }

  // Accuracy against the sparse points (sparse_agreement.py).
  if (!args.sparse_points.empty()) {
    const std::vector<SparsePoint> sparse = readSparsePoints(args.sparse_points);
    Agreement depth_agreement, map_agreement;
    for (const auto& d : latest_depth) {
      const auto info = infos.find(d.first);
      const auto pose = poses.find(d.first);
      if (info == infos.end() || pose == poses.end()) continue;
      const int view = static_cast<int>(std::find(image_stamps.begin(), image_stamps.end(), d.second->header.stamp) -
                                        image_stamps.begin());
      const Camera camera(*info->second, pose->second);
      const sensor_msgs::Image* depth = d.second;
      agreement(sparse, camera, view, [&](int u, int v) { return double(floats(*depth)[v * depth->width + u]); },
                &depth_agreement);
      // The map rendered into the camera, 1 px splats (render_depth).
      std::vector<double> zbuffer(static_cast<size_t>(camera.width) * camera.height,
                                  std::numeric_limits<double>::infinity());
      for (const auto& p : map_points) {
        int u, v;
        double z;
        if (!camera.pixel(p[0], p[1], p[2], &u, &v, &z)) continue;
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du) {
            const int uu = u + du, vv = v + dv;
            if (uu < 0 || vv < 0 || uu >= camera.width || vv >= camera.height) continue;
            double& cell = zbuffer[static_cast<size_t>(vv) * camera.width + uu];
            cell = std::min(cell, z);
          }
      }
      agreement(sparse, camera, view, [&](int u, int v) { return zbuffer[static_cast<size_t>(v) * camera.width + u]; },
                &map_agreement);
    }
    const long t = std::max(depth_agreement.total, 1L);
    double p[3], q[3];
    for (int i = 0; i < 3; ++i) p[i] = 100.0 * depth_agreement.within[i] / t;
    report.check(depth_agreement.total > 1000 && p[0] >= args.depth_floors[0] && p[1] >= args.depth_floors[1] &&
                     p[2] >= args.depth_floors[2],
                 "depth_vs_sparse_points",
                 fmt("%.1f / %.1f / %.1f %% within 1 / 2 / 5 %% over %ld observations (floors %.1f / %.1f / %.1f)",
                     p[0], p[1], p[2], depth_agreement.total, args.depth_floors[0], args.depth_floors[1],
                     args.depth_floors[2]));
    const long covered = std::max(map_agreement.finite, 1L);
    for (int i = 0; i < 3; ++i) q[i] = 100.0 * map_agreement.within[i] / covered;
    const double coverage = 100.0 * map_agreement.finite / std::max(map_agreement.total, 1L);
    report.check(q[0] >= args.map_floors[0] && q[1] >= args.map_floors[1] && q[2] >= args.map_floors[2] &&
                     coverage >= args.min_map_coverage,
                 "map_vs_sparse_points",
                 fmt("%.1f / %.1f / %.1f %% within 1 / 2 / 5 %% of the %ld covered observations (%.1f %% of %ld; "
                     "floors %.1f / %.1f / %.1f, coverage %.1f)",
                     q[0], q[1], q[2], map_agreement.finite, coverage, map_agreement.total, args.map_floors[0],
                     args.map_floors[1], args.map_floors[2], args.min_map_coverage));
  }

  if (!libraries.empty()) report.line(libraries);
  report.line(fmt("RESULT %s: %d passed, %d failed, %.1f s in all", report.failed ? "FAIL" : "PASS", report.passed,
                  report.failed, secondsSince(start)));
  if (!args.report.empty()) std::ofstream(args.report) << report.text.str();
  spinner.stop();
  ros::shutdown();
  master.stop();
  return report.failed ? 1 : 0;
}
