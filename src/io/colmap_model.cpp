#include "amhmvs_mapping/io/colmap_model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "file_util.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

struct ColmapCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

struct ColmapImage {
  int id = -1;
  double qw = 1, qx = 0, qy = 0, qz = 0;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int camera_id = -1;
  std::string name;
};

struct ColmapPoint {
  Eigen::Vector3d xyz;
  std::vector<int> image_ids;  // may repeat an image (several 2D features)
};

struct ColmapModel {
  std::map<int, ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint> points;
};

const char* const kUndistortHint =
    " (only PINHOLE and SIMPLE_PINHOLE are supported; run `colmap image_undistorter` first)";

// Builds a camera from COLMAP parameters; `where` prefixes errors.
ColmapCamera makeCamera(const std::string& model, long long width, long long height,
                        const std::vector<double>& params, const std::string& where) {
  ColmapCamera cam;
  size_t expected = 0;
  if (model == "SIMPLE_PINHOLE") {
    expected = 3;
  } else if (model == "PINHOLE") {
    expected = 4;
  } else {
    throw InputError(where + "unsupported camera model " + model + kUndistortHint);
  }
  if (params.size() != expected) {
    throw InputError(where + model + " needs " + std::to_string(expected) + " parameters, got " +
                     std::to_string(params.size()));
  }
  if (width <= 0 || height <= 0 || width > (1 << 20) || height > (1 << 20)) {
    throw InputError(where + "invalid image size " + std::to_string(width) + "x" +
                     std::to_string(height));
  }
  cam.width = static_cast<int>(width);
  cam.height = static_cast<int>(height);
  if (expected == 3) {
    cam.fx = cam.fy = params[0];
    cam.cx = params[1];
    cam.cy = params[2];
  } else {
    cam.fx = params[0];
    cam.fy = params[1];
    cam.cx = params[2];
    cam.cy = params[3];
  }
  return cam;
}

// ---- Text model --------------------------------------------------------------

// Lines of a COLMAP text file; comment lines ('#') are dropped but numbering kept.
struct TextLine {
  int number;
  std::string text;
};

std::vector<TextLine> readTextLines(const std::string& path) {
  std::istringstream in(internal::readFileBytes(path));
  std::vector<TextLine> lines;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line[first] == '#') continue;
    lines.push_back({number, line});
  }
  return lines;
}

std::string lineWhere(const std::string& path, int line) {
  return path + ": line " + std::to_string(line) + ": ";
}

double textDouble(const std::string& token, const std::string& where, const char* what) {
  double v;
  if (!internal::parseDouble(token, &v)) {
    throw InputError(where + "expected a number for " + what + ", got '" +
                     internal::excerpt(token, 20) + "'");
  }
  return v;
}

long long textInt(const std::string& token, const std::string& where, const char* what) {
  long long v;
  if (!internal::parseInt(token, &v)) {
    throw InputError(where + "expected an integer for " + what + ", got '" +
                     internal::excerpt(token, 20) + "'");
  }
  return v;
}

int textId(const std::string& token, const std::string& where, const char* what) {
  const long long v = textInt(token, where, what);
  if (v < 0 || v > 0x7fffffff) {
    throw InputError(where + std::string(what) + " out of range: " + token);
  }
  return static_cast<int>(v);
}

void readCamerasText(const std::string& path, ColmapModel* model) {
  for (const TextLine& line : readTextLines(path)) {
    const std::vector<std::string> tok = internal::splitWhitespace(line.text);
    if (tok.empty()) continue;
    const std::string where = lineWhere(path, line.number);
    if (tok.size() < 4) {
      throw InputError(where + "expected 'CAMERA_ID MODEL WIDTH HEIGHT PARAMS...', got '" +
                       internal::excerpt(line.text) + "'");
    }
    const int id = textId(tok[0], where, "camera id");
    std::vector<double> params;
    for (size_t i = 4; i < tok.size(); ++i) params.push_back(textDouble(tok[i], where, "param"));
    const ColmapCamera cam = makeCamera(tok[1], textInt(tok[2], where, "width"),
                                        textInt(tok[3], where, "height"), params, where);
    if (!model->cameras.emplace(id, cam).second) {
      throw InputError(where + "camera id " + std::to_string(id) + " appears twice");
    }
  }
}

void readImagesText(const std::string& path, ColmapModel* model) {
  const std::vector<TextLine> lines = readTextLines(path);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::vector<std::string> tok = internal::splitWhitespace(lines[i].text);
    if (tok.empty()) continue;  // blank lines between records
    const std::string where = lineWhere(path, lines[i].number);
    if (tok.size() < 10) {
      throw InputError(where + "expected 'IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME', got '" +
                       internal::excerpt(lines[i].text) + "'");
    }
    ColmapImage image;
    image.id = textId(tok[0], where, "image id");
    image.qw = textDouble(tok[1], where, "QW");
    image.qx = textDouble(tok[2], where, "QX");
    image.qy = textDouble(tok[3], where, "QY");
    image.qz = textDouble(tok[4], where, "QZ");
    for (int k = 0; k < 3; ++k) image.t[k] = textDouble(tok[5 + k], where, "translation");
    image.camera_id = textId(tok[8], where, "camera id");
    // The name is the rest of the line, so names with spaces survive.
    std::istringstream rest(lines[i].text);
    std::string skip;
    for (int k = 0; k < 9; ++k) rest >> skip;
    std::getline(rest >> std::ws, image.name);
    while (!image.name.empty() && (image.name.back() == ' ' || image.name.back() == '\t')) {
      image.name.pop_back();
    }
    model->images.push_back(image);
    ++i;  // the POINTS2D line follows (possibly empty); the tracks in points3D suffice
  }
}

void readPointsText(const std::string& path, ColmapModel* model) {
  for (const TextLine& line : readTextLines(path)) {
    const std::vector<std::string> tok = internal::splitWhitespace(line.text);
    if (tok.empty()) continue;
    const std::string where = lineWhere(path, line.number);
    if (tok.size() < 8 || (tok.size() - 8) % 2 != 0) {
      throw InputError(where + "expected 'POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)...'"
                       ", got " + std::to_string(tok.size()) + " fields");
    }
    ColmapPoint point;
    for (int k = 0; k < 3; ++k) point.xyz[k] = textDouble(tok[1 + k], where, "point coordinate");
    for (size_t k = 8; k < tok.size(); k += 2) {
      point.image_ids.push_back(textId(tok[k], where, "track image id"));
    }
    model->points.push_back(std::move(point));
  }
}

// ---- Binary model (little-endian, COLMAP's Write*Binary layout) ------------------

class BinaryReader {
 public:
  explicit BinaryReader(const std::string& path)
      : path_(path), bytes_(internal::readFileBytes(path)) {}

  uint64_t u64(const char* what) { return little(8, what); }
  uint32_t u32(const char* what) { return static_cast<uint32_t>(little(4, what)); }
  int32_t i32(const char* what) { return static_cast<int32_t>(little(4, what)); }
  // A uint32 id; ids above INT_MAX are refused (they would become negative
  // view ids), as the text reader refuses them.
  int id(const char* what) {
    const uint32_t v = u32(what);
    if (v > 0x7fffffffu) fail(std::string(what) + " " + std::to_string(v) + " out of range (max 2147483647)");
    return static_cast<int>(v);
  }
  double f64(const char* what) {
    const uint64_t bits = little(8, what);
    double v;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
  }
  void skip(uint64_t n, const char* what) {
    need(n, what);
    pos_ += n;
  }
  std::string cstring(const char* what) {
    const size_t end = bytes_.find('\0', pos_);
    if (end == std::string::npos) fail(std::string("unterminated ") + what);
    std::string s = bytes_.substr(pos_, end - pos_);
    pos_ = end + 1;
    return s;
  }
  // Guards allocations against corrupt counts: each item needs >= min_bytes.
  void checkCount(uint64_t count, uint64_t min_bytes, const char* what) {
    if (count > (bytes_.size() - pos_) / min_bytes) {
      fail("truncated or corrupt file (" + std::string(what) + " count " +
           std::to_string(count) + " needs more than the " +
           std::to_string(bytes_.size() - pos_) + " bytes left)");
    }
  }
  bool atEnd() const { return pos_ == bytes_.size(); }
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_ + ": at byte " + std::to_string(pos_) + ": " + problem);
  }
  const std::string& path() const { return path_; }

 private:
  void need(uint64_t n, const char* what) {
    if (n > bytes_.size() - pos_) fail(std::string("truncated file (reading ") + what + ")");
  }
  uint64_t little(int n, const char* what) {
    need(n, what);
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(bytes_[pos_ + i]);
    pos_ += n;
    return v;
  }

  std::string path_;
  std::string bytes_;
  size_t pos_ = 0;
};

const char* binaryModelName(int id) {
  static const char* const kNames[] = {"SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL",
                                       "OPENCV", "OPENCV_FISHEYE", "FULL_OPENCV", "FOV",
                                       "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE",
                                       "THIN_PRISM_FISHEYE", "RAD_TAN_THIN_PRISM_FISHEYE"};
  return id >= 0 && id < 12 ? kNames[id] : "unknown";
}

void readCamerasBinary(const std::string& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t count = in.u64("camera count");
  in.checkCount(count, 24, "camera");
  for (uint64_t i = 0; i < count; ++i) {
    const int id = in.id("camera id");
    const int model_id = in.i32("camera model");
    const uint64_t width = in.u64("width");
    const uint64_t height = in.u64("height");
    const std::string where = path + ": camera " + std::to_string(id) + ": ";
    if (model_id != 0 && model_id != 1) {
      throw InputError(where + "unsupported camera model " + binaryModelName(model_id) +
                       " (id " + std::to_string(model_id) + ")" + kUndistortHint);
    }
    std::vector<double> params(model_id == 0 ? 3 : 4);
    for (double& p : params) p = in.f64("camera parameter");
    for (double p : params) {
      if (!std::isfinite(p)) throw InputError(where + "non-finite camera parameter");
    }
    const long long w = width > (1u << 30) ? -1 : static_cast<long long>(width);
    const long long h = height > (1u << 30) ? -1 : static_cast<long long>(height);
    const ColmapCamera cam = makeCamera(binaryModelName(model_id), w, h, params, where);
    if (!model->cameras.emplace(id, cam).second) {
      throw InputError(where + "camera id appears twice");
    }
  }
  if (!in.atEnd()) in.fail("unexpected data after the last camera");
}

void readImagesBinary(const std::string& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t count = in.u64("image count");
  in.checkCount(count, 4 + 7 * 8 + 4 + 1 + 8, "image");
  for (uint64_t i = 0; i < count; ++i) {
    ColmapImage image;
    image.id = in.id("image id");
    image.qw = in.f64("qvec");
    image.qx = in.f64("qvec");
    image.qy = in.f64("qvec");
    image.qz = in.f64("qvec");
    for (int k = 0; k < 3; ++k) image.t[k] = in.f64("tvec");
    image.camera_id = in.id("camera id");
    image.name = in.cstring("image name");
    const uint64_t num_points2d = in.u64("2D point count");
    in.checkCount(num_points2d, 24, "2D point");
    in.skip(num_points2d * 24, "2D points");  // x, y (double), point3D id (int64)
    model->images.push_back(image);
  }
  if (!in.atEnd()) in.fail("unexpected data after the last image");
}

void readPointsBinary(const std::string& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t count = in.u64("point count");
  in.checkCount(count, 8 + 24 + 3 + 8 + 8, "point");
  model->points.reserve(count);
  for (uint64_t i = 0; i < count; ++i) {
    ColmapPoint point;
    in.u64("point id");
    for (int k = 0; k < 3; ++k) point.xyz[k] = in.f64("point coordinate");
    in.skip(3 + 8, "colour and error");
    const uint64_t track = in.u64("track length");
    in.checkCount(track, 8, "track element");
    point.image_ids.reserve(track);
    for (uint64_t k = 0; k < track; ++k) {
      point.image_ids.push_back(in.id("track image id"));
      in.u32("track point2D index");
    }
    model->points.push_back(std::move(point));
  }
  if (!in.atEnd()) in.fail("unexpected data after the last point");
}

// ---- Scene assembly ----------------------------------------------------------------

void checkOptions(const ColmapOptions& o) {
  auto bad = [](const std::string& what) {
    throw InputError("ColmapOptions: invalid " + what);
  };
  if (!(o.depth_low_percentile >= 0 && o.depth_low_percentile <= o.depth_high_percentile &&
        o.depth_high_percentile <= 1)) {
    bad("depth percentiles (need 0 <= depth_low_percentile <= depth_high_percentile <= 1)");
  }
  if (!(o.depth_min_scale > 0 && std::isfinite(o.depth_min_scale))) bad("depth_min_scale");
  if (!(o.depth_max_scale > 0 && std::isfinite(o.depth_max_scale))) bad("depth_max_scale");
  if (o.min_points < 1) bad("min_points (must be >= 1)");
  if (!std::isfinite(o.theta0_deg)) bad("theta0_deg");
  if (!(o.sigma1_deg > 0 && std::isfinite(o.sigma1_deg))) bad("sigma1_deg (must be > 0)");
  if (!(o.sigma2_deg > 0 && std::isfinite(o.sigma2_deg))) bad("sigma2_deg (must be > 0)");
  if (o.max_sources < 0) bad("max_sources (must be >= 0)");
}

double quantile(const std::vector<double>& sorted, double p) {
  const double pos = p * static_cast<double>(sorted.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(sorted.size() - 1, lo + 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

bool allExist(const fs::path& dir, const char* ext) {
  std::error_code ec;
  for (const char* name : {"cameras", "images", "points3D"}) {
    if (!fs::is_regular_file(dir / (std::string(name) + ext), ec)) return false;
  }
  return true;
}

Scene buildScene(const ColmapModel& model, const std::string& images_file,
                 const std::string& points_file, const std::string& image_dir,
                 const ColmapOptions& options) {
  Scene scene;
  std::vector<ColmapImage> images = model.images;
  std::sort(images.begin(), images.end(),
            [](const ColmapImage& a, const ColmapImage& b) { return a.id < b.id; });
  std::unordered_map<int, int> index_of_id;
  for (const ColmapImage& image : images) {
    const std::string where = images_file + ": image " + std::to_string(image.id) + " ('" +
                              internal::excerpt(image.name) + "'): ";
    if (!index_of_id.emplace(image.id, static_cast<int>(scene.views.size())).second) {
      throw InputError(where + "image id appears twice");
    }
    const auto cam = model.cameras.find(image.camera_id);
    if (cam == model.cameras.end()) {
      throw InputError(where + "unknown camera id " + std::to_string(image.camera_id));
    }
    const Eigen::Quaterniond q(image.qw, image.qx, image.qy, image.qz);
    // Scaled by its largest component before the norm, which would overflow
    // for components near 1e300 (and normalise to a wrong pose).
    // COLMAP writes unit quaternions: a norm outside [1e-6, 1e6] is corruption.
    const double q_scale = q.coeffs().cwiseAbs().maxCoeff();
    const double q_norm = q_scale > 0 ? (q.coeffs() / q_scale).norm() * q_scale : 0.0;
    if (!q.coeffs().allFinite() || !(q_norm >= 1e-6 && q_norm <= 1e6)) {
      std::ostringstream values;
      values << "(" << image.qw << ", " << image.qx << ", " << image.qy << ", " << image.qz
             << "), norm " << q_norm;
      throw InputError(where + "invalid rotation quaternion " + values.str() +
                       " (need finite components and a norm in [1e-6, 1e6])");
    }
    const Eigen::Quaterniond unit(q.coeffs() / q_scale);
    const fs::path name(image.name);
    if (name.empty() || name.is_absolute() ||
        std::any_of(name.begin(), name.end(), [](const fs::path& part) { return part == ".."; })) {
      throw InputError(where + "image name must be a relative path inside the image folder "
                       "(no absolute path, no '..')");
    }
    SceneView view;
    view.id = image.id;
    view.name = image.name;
    view.image_path = (fs::path(image_dir) / name).string();
    PinholeCamera& c = view.camera;
    c.fx = cam->second.fx;
    c.fy = cam->second.fy;
    c.cx = cam->second.cx;
    c.cy = cam->second.cy;
    c.width = cam->second.width;
    c.height = cam->second.height;
    c.R = unit.normalized().toRotationMatrix();
    c.t = image.t;
    const std::string why = c.validate();
    if (!why.empty()) throw InputError(where + "invalid camera: " + why);

    std::error_code ec;
    if (!fs::is_regular_file(view.image_path, ec)) {
      throw InputError(where + "image file not found: " + view.image_path);
    }
    int w = 0, h = 0;
    if (readImageSize(view.image_path, &w, &h) && (w != c.width || h != c.height)) {
      throw InputError(where + "image " + view.image_path + " is " + std::to_string(w) + "x" +
                       std::to_string(h) + " but its camera is " + std::to_string(c.width) +
                       "x" + std::to_string(c.height) +
                       " (use the images that image_undistorter wrote)");
    }
    scene.views.push_back(view);
  }

  const size_t n = scene.views.size();
  std::vector<Eigen::Vector3d> centers(n);
  for (size_t i = 0; i < n; ++i) centers[i] = scene.views[i].camera.center();
  std::vector<std::vector<double>> depths(n);
  std::vector<std::unordered_map<int, double>> scores(n);
  const double deg = 3.14159265358979323846 / 180.0;
  std::vector<int> track;
  for (size_t p = 0; p < model.points.size(); ++p) {
    const ColmapPoint& point = model.points[p];
    if (!point.xyz.allFinite()) {
      throw InputError(points_file + ": point #" + std::to_string(p + 1) +
                       " has non-finite coordinates");
    }
    track.clear();
    for (int id : point.image_ids) {
      const auto it = index_of_id.find(id);
      if (it == index_of_id.end()) {
        throw InputError(points_file + ": point #" + std::to_string(p + 1) +
                         " is observed by unknown image id " + std::to_string(id));
      }
      track.push_back(it->second);
    }
    std::sort(track.begin(), track.end());
    track.erase(std::unique(track.begin(), track.end()), track.end());
    for (int v : track) {
      const double z = scene.views[v].camera.toCamera(point.xyz).z();
      if (z > 0) depths[v].push_back(z);
    }
    for (size_t a = 0; a < track.size(); ++a) {
      for (size_t b = a + 1; b < track.size(); ++b) {
        const double theta =
            triangulationAngle(centers[track[a]], centers[track[b]], point.xyz) / deg;
        const double sigma = theta <= options.theta0_deg ? options.sigma1_deg : options.sigma2_deg;
        const double d = theta - options.theta0_deg;
        const double w = std::exp(-d * d / (2 * sigma * sigma));
        scores[track[a]][track[b]] += w;
        scores[track[b]][track[a]] += w;
      }
    }
  }

  for (size_t i = 0; i < n; ++i) {
    SceneView& view = scene.views[i];
    std::vector<double>& z = depths[i];
    if (z.size() < static_cast<size_t>(options.min_points)) {
      throw InputError(images_file + ": image " + std::to_string(view.id) + " ('" + view.name +
                       "') observes " + std::to_string(z.size()) +
                       " sparse points in front of it; at least " +
                       std::to_string(options.min_points) + " are needed for a depth range");
    }
    std::sort(z.begin(), z.end());
    view.depth_min = quantile(z, options.depth_low_percentile) * options.depth_min_scale;
    view.depth_max = quantile(z, options.depth_high_percentile) * options.depth_max_scale;
    if (!(std::isfinite(view.depth_min) && std::isfinite(view.depth_max) &&
          view.depth_min > 0 && view.depth_max > view.depth_min)) {
      throw InputError(images_file + ": image " + std::to_string(view.id) + " ('" + view.name +
                       "'): degenerate depth range from its sparse points");
    }
    const std::string conditioning = conditioningProblem(view.camera, view.depth_min, view.depth_max);
    if (!conditioning.empty()) {
      throw InputError(images_file + ": image " + std::to_string(view.id) + " ('" + view.name +
                       "'): " + conditioning);
    }

    std::vector<SourceCandidate> sources;
    for (const auto& [j, score] : scores[i]) {
      if (score > 0) sources.push_back({scene.views[j].id, score});
    }
    // Ties broken by id so the order never depends on hash-map iteration.
    std::sort(sources.begin(), sources.end(),
              [](const SourceCandidate& a, const SourceCandidate& b) {
                return a.score != b.score ? a.score > b.score : a.view_id < b.view_id;
              });
    if (sources.size() > static_cast<size_t>(options.max_sources)) {
      sources.resize(options.max_sources);
    }
    scene.sources[view.id] = std::move(sources);
  }
  return scene;
}

}  // namespace

Scene readColmapModel(const std::string& sparse_dir, const std::string& image_dir,
                      const ColmapOptions& options) {
  checkOptions(options);
  const fs::path dir(sparse_dir);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(sparse_dir + ": not a directory");
  if (!fs::is_directory(image_dir, ec)) throw InputError(image_dir + ": image folder not found");

  bool binary;
  switch (options.format) {
    case ColmapOptions::Format::kBinary:
      binary = true;
      break;
    case ColmapOptions::Format::kText:
      binary = false;
      break;
    default:
      binary = allExist(dir, ".bin");
      if (!binary && !allExist(dir, ".txt")) {
        throw InputError(sparse_dir +
                         ": no COLMAP model (need cameras, images and points3D as .bin or .txt)");
      }
  }
  const std::string ext = binary ? ".bin" : ".txt";
  const std::string cameras = (dir / ("cameras" + ext)).string();
  const std::string images = (dir / ("images" + ext)).string();
  const std::string points = (dir / ("points3D" + ext)).string();

  ColmapModel model;
  if (binary) {
    readCamerasBinary(cameras, &model);
    readImagesBinary(images, &model);
    readPointsBinary(points, &model);
  } else {
    readCamerasText(cameras, &model);
    readImagesText(images, &model);
    readPointsText(points, &model);
  }
  if (model.images.empty()) throw InputError(images + ": model has no images");
  return buildScene(model, images, points, image_dir, options);
}

Scene readColmapWorkspace(const std::string& dir, const ColmapOptions& options) {
  const fs::path root(dir);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw InputError(dir + ": not a directory");
  fs::path sparse = root / "sparse";
  if (!allExist(sparse, ".bin") && !allExist(sparse, ".txt")) {
    if (allExist(sparse / "0", ".bin") || allExist(sparse / "0", ".txt")) {
      sparse /= "0";
    } else {
      throw InputError(dir + ": no COLMAP model in sparse/ or sparse/0/ (expected the output of "
                       "`colmap image_undistorter`)");
    }
  }
  const fs::path images = root / "images";
  if (!fs::is_directory(images, ec)) {
    throw InputError(dir + ": missing images/ folder next to sparse/");
  }
  return readColmapModel(sparse.string(), images.string(), options);
}

}  // namespace amhmvs
