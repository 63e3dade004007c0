#include "amhmvs_mapping/io/mvsnet_folder.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"
#include "amhmvs_mapping/io/image_io.h"
#include "file_util.h"
#include "text_lines.h"

namespace amhmvs {

namespace fs = std::filesystem;

namespace {

// Reads the lines of a text file; `next` skips blank lines and remembers the
// 1-based line number for error messages.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : path_(path) {
    std::istringstream in(internal::readFileBytes(path));
    std::string line;
    while (std::getline(in, line)) lines_.push_back(line);
  }

  // Next non-blank line, or false at end of file.
  bool next(std::string* line) {
    while (index_ < lines_.size()) {
      const std::string& l = lines_[index_++];
      if (l.find_first_not_of(" \t\r") != std::string::npos) {
        *line = l;
        return true;
      }
    }
    return false;
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_ + ": line " + std::to_string(index_) + ": " + problem);
  }

  std::string nextOrFail(const std::string& what) {
    std::string line;
    if (!next(&line)) {
      throw InputError(path_ + ": unexpected end of file (missing " + what + ")");
    }
    return line;
  }

  void expectKeyword(const std::string& keyword) {
    const std::string line = nextOrFail("'" + keyword + "'");
    const std::vector<std::string> tokens = internal::splitWhitespace(line);
    if (tokens.size() != 1 || tokens[0] != keyword) {
      fail("expected '" + keyword + "', got '" + internal::excerpt(line) + "'");
    }
  }

  // A line of between min_count and max_count numbers.
  std::vector<double> numbers(size_t min_count, size_t max_count, const std::string& what) {
    const std::string line = nextOrFail(what);
    const std::vector<std::string> tokens = internal::splitWhitespace(line);
    const std::string expected = min_count == max_count
                                     ? std::to_string(min_count)
                                     : std::to_string(min_count) + " to " +
                                           std::to_string(max_count);
    std::vector<double> values(tokens.size());
    for (size_t i = 0; i < tokens.size(); ++i) {
      if (!internal::parseDouble(tokens[i], &values[i])) {
        fail("expected " + expected + " numbers for " + what + ", got '" +
             internal::excerpt(line) + "' ('" + internal::excerpt(tokens[i], 20) +
             "' is not a finite number)");
      }
    }
    if (tokens.size() < min_count || tokens.size() > max_count) {
      fail("expected " + expected + " numbers for " + what + ", got " +
           std::to_string(tokens.size()) + " ('" + internal::excerpt(line) + "')");
    }
    return values;
  }

 private:
  std::string path_;
  std::vector<std::string> lines_;
  size_t index_ = 0;
};

// Whitespace-separated tokens with their line numbers (pair.txt is read by
// token, as the reference implementation does, but errors still name lines).
struct Token {
  std::string text;
  int line;
};

std::vector<Token> tokenize(const std::string& path) {
  std::istringstream in(internal::readFileBytes(path));
  std::vector<Token> tokens;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    for (const std::string& t : internal::splitWhitespace(line)) tokens.push_back({t, number});
  }
  return tokens;
}

bool isDigits(const std::string& s) {
  return !s.empty() && s.size() <= 9 &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::string formatCamNumber(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", v);
  return buffer;
}

void checkDepthRange(const std::string& path, double depth_min, double depth_max) {
  if (!(std::isfinite(depth_min) && std::isfinite(depth_max) && depth_min > 0 &&
        depth_max > depth_min)) {
    throw InputError(path + ": invalid depth range (depth_min=" + formatCamNumber(depth_min) +
                     ", depth_max=" + formatCamNumber(depth_max) +
                     "; need finite 0 < depth_min < depth_max)");
  }
}

}  // namespace

void readMvsnetCam(const std::string& path, PinholeCamera* camera, double* depth_min,
                   double* depth_max) {
  LineReader reader(path);
  reader.expectKeyword("extrinsic");
  Eigen::Matrix4d extrinsic;
  for (int r = 0; r < 4; ++r) {
    const std::vector<double> row = reader.numbers(4, 4, "extrinsic row");
    for (int c = 0; c < 4; ++c) extrinsic(r, c) = row[c];
  }
  if ((extrinsic.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
    reader.fail("extrinsic bottom row must be '0 0 0 1'");
  }
  reader.expectKeyword("intrinsic");
  Eigen::Matrix3d k;
  for (int r = 0; r < 3; ++r) {
    const std::vector<double> row = reader.numbers(3, 3, "intrinsic row");
    for (int c = 0; c < 3; ++c) k(r, c) = row[c];
  }
  // Only skew-free pinholes are supported; anything else would be silently
  // misread as one.
  if (std::abs(k(0, 1)) > 1e-9 * std::max(1.0, std::abs(k(0, 0)))) {
    reader.fail("intrinsic has non-zero skew K[0][1]=" + formatCamNumber(k(0, 1)) +
                " (only skew-free pinhole cameras are supported)");
  }
  if (std::abs(k(1, 0)) > 1e-9 || std::abs(k(2, 0)) > 1e-9 || std::abs(k(2, 1)) > 1e-9 ||
      std::abs(k(2, 2) - 1.0) > 1e-9) {
    reader.fail("intrinsic is not of the form [fx 0 cx; 0 fy cy; 0 0 1]");
  }

  const std::vector<double> depth = reader.numbers(2, 4, "depth range line");
  double dmin = depth[0];
  double dmax;
  if (depth.size() == 4) {
    dmax = depth[3];
  } else {
    const double num = depth.size() >= 3 ? depth[2] : 192.0;
    if (num < 2 || num != std::floor(num)) {
      reader.fail("depth_num must be an integer >= 2, got " + formatCamNumber(num));
    }
    dmax = dmin + depth[1] * (num - 1);
  }
  std::string extra;
  if (reader.next(&extra)) {
    reader.fail("unexpected content after the depth range line: '" + internal::excerpt(extra) +
                "'");
  }
  checkDepthRange(path, dmin, dmax);

  camera->fx = k(0, 0);
  camera->fy = k(1, 1);
  camera->cx = k(0, 2);
  camera->cy = k(1, 2);
  camera->width = 0;
  camera->height = 0;
  camera->R = extrinsic.topLeftCorner<3, 3>();
  camera->t = extrinsic.topRightCorner<3, 1>();
  *depth_min = dmin;
  *depth_max = dmax;
}

std::map<int, std::vector<SourceCandidate>> readMvsnetPair(const std::string& path) {
  const std::vector<Token> tokens = tokenize(path);
  size_t pos = 0;
  auto fail = [&](const std::string& problem) {
    const int line = pos < tokens.size() ? tokens[pos].line
                                         : (tokens.empty() ? 1 : tokens.back().line);
    throw InputError(path + ": line " + std::to_string(line) + ": " + problem);
  };
  auto next_int = [&](const std::string& what, long long min_value) {
    if (pos >= tokens.size()) {
      throw InputError(path + ": unexpected end of file (missing " + what + ")");
    }
    long long v;
    if (!internal::parseInt(tokens[pos].text, &v) || v < min_value || v > 999999999) {
      fail("expected " + what + ", got '" + internal::excerpt(tokens[pos].text, 20) + "'");
    }
    ++pos;
    return static_cast<int>(v);
  };

  std::map<int, std::vector<SourceCandidate>> pairs;
  const int count = next_int("view count", 0);
  for (int i = 0; i < count; ++i) {
    const int ref = next_int("reference view id", 0);
    if (pairs.count(ref)) {
      --pos;
      fail("reference view " + std::to_string(ref) + " is listed twice");
    }
    std::vector<SourceCandidate>& sources = pairs[ref];
    const int n = next_int("number of source views", 0);
    std::set<int> seen;
    for (int j = 0; j < n; ++j) {
      SourceCandidate candidate;
      candidate.view_id = next_int("source view id", 0);
      if (candidate.view_id == ref) {
        --pos;
        fail("view " + std::to_string(ref) + " is paired with itself");
      }
      if (!seen.insert(candidate.view_id).second) {
        --pos;
        fail("source view " + std::to_string(candidate.view_id) + " repeats for reference " +
             std::to_string(ref));
      }
      if (pos >= tokens.size()) {
        throw InputError(path + ": unexpected end of file (missing score)");
      }
      if (!internal::parseDouble(tokens[pos].text, &candidate.score)) {
        fail("expected a score, got '" + internal::excerpt(tokens[pos].text, 20) + "'");
      }
      ++pos;
      sources.push_back(candidate);
    }
  }
  if (pos < tokens.size()) {
    fail("unexpected content after " + std::to_string(count) + " views: '" +
         internal::excerpt(tokens[pos].text, 20) + "'");
  }
  return pairs;
}

Scene readMvsnetDenseFolder(const std::string& dir) {
  const fs::path root(dir);
  const fs::path image_dir = root / "images";
  const fs::path cam_dir = root / "cams";
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw InputError(dir + ": not a directory");
  if (!fs::is_directory(image_dir, ec)) {
    throw InputError(image_dir.string() + ": missing 'images' folder in MVSNet dense folder");
  }
  if (!fs::is_directory(cam_dir, ec)) {
    throw InputError(cam_dir.string() + ": missing 'cams' folder in MVSNet dense folder");
  }

  // Images: <digits>.<supported ext>; other files (thumbnails, notes) are ignored.
  std::map<int, fs::path> images;
  std::vector<fs::path> entries;
  for (const auto& entry : fs::directory_iterator(image_dir, ec)) entries.push_back(entry.path());
  if (ec) throw InputError(image_dir.string() + ": cannot list folder (" + ec.message() + ")");
  std::sort(entries.begin(), entries.end());
  for (const fs::path& p : entries) {
    if (!isDigits(p.stem().string()) || !hasImageExtension(p.string())) continue;
    const int id = std::stoi(p.stem().string());
    const auto inserted = images.emplace(id, p);
    if (!inserted.second) {
      throw InputError(image_dir.string() + ": two images share view id " + std::to_string(id) +
                       " (" + inserted.first->second.filename().string() + ", " +
                       p.filename().string() + ")");
    }
  }

  // Cams: <digits>_cam.txt.
  std::map<int, fs::path> cams;
  entries.clear();
  for (const auto& entry : fs::directory_iterator(cam_dir, ec)) entries.push_back(entry.path());
  if (ec) throw InputError(cam_dir.string() + ": cannot list folder (" + ec.message() + ")");
  std::sort(entries.begin(), entries.end());
  const std::string suffix = "_cam.txt";
  for (const fs::path& p : entries) {
    const std::string name = p.filename().string();
    if (name.size() <= suffix.size() ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) {
      continue;
    }
    const std::string stem = name.substr(0, name.size() - suffix.size());
    if (!isDigits(stem)) continue;
    const int id = std::stoi(stem);
    const auto inserted = cams.emplace(id, p);
    if (!inserted.second) {
      throw InputError(cam_dir.string() + ": two cam files share view id " + std::to_string(id) +
                       " (" + inserted.first->second.filename().string() + ", " + name + ")");
    }
  }
  if (cams.empty()) {
    throw InputError(cam_dir.string() + ": no cam files (expected %08d_cam.txt)");
  }

  Scene scene;
  for (const auto& [id, cam_path] : cams) {
    const std::string cam_file = cam_path.string();
    const auto image = images.find(id);
    if (image == images.end()) {
      char expected[32];
      std::snprintf(expected, sizeof(expected), "%08d", id);
      throw InputError(cam_file + ": no image for this camera (expected images/" + expected +
                       ".<png|jpg|...>)");
    }
    SceneView view;
    view.id = id;
    view.name = image->second.filename().string();
    view.image_path = image->second.string();
    readMvsnetCam(cam_file, &view.camera, &view.depth_min, &view.depth_max);
    int width = 0, height = 0;
    if (!readImageSize(view.image_path, &width, &height)) {
      const ImageU8 decoded = readImage(view.image_path);  // formats without a sizer
      width = decoded.width;
      height = decoded.height;
    }
    view.camera.width = width;
    view.camera.height = height;
    std::string why = view.camera.validate();
    if (why.empty()) why = conditioningProblem(view.camera, view.depth_min, view.depth_max);
    if (!why.empty()) throw InputError(cam_file + ": invalid camera: " + why);
    scene.views.push_back(view);
  }

  const fs::path pair_path = root / "pair.txt";
  if (fs::exists(pair_path, ec)) {
    const std::string pair_file = pair_path.string();
    scene.sources = readMvsnetPair(pair_file);
    for (auto& [ref, sources] : scene.sources) {
      if (scene.indexOf(ref) < 0) {
        throw InputError(pair_file + ": reference view " + std::to_string(ref) +
                         " has no cam file");
      }
      for (const SourceCandidate& s : sources) {
        if (scene.indexOf(s.view_id) < 0) {
          throw InputError(pair_file + ": source view " + std::to_string(s.view_id) +
                           " (of reference " + std::to_string(ref) + ") has no cam file");
        }
      }
      // Best first, as Scene promises; stable so equal scores keep file order.
      std::stable_sort(sources.begin(), sources.end(),
                       [](const SourceCandidate& a, const SourceCandidate& b) {
                         return a.score > b.score;
                       });
    }
  }
  return scene;
}

void writeMvsnetCam(const std::string& path, const PinholeCamera& camera, double depth_min,
                    double depth_max) {
  PinholeCamera sized = camera;  // the cam format has no image size to check
  sized.width = std::max(1, sized.width);
  sized.height = std::max(1, sized.height);
  const std::string why = sized.validate();
  if (!why.empty()) throw InputError(path + ": refusing to write invalid camera: " + why);
  checkDepthRange(path, depth_min, depth_max);

  const auto n = formatCamNumber;
  std::ostringstream out;
  out << "extrinsic\n";
  for (int r = 0; r < 3; ++r) {
    out << n(camera.R(r, 0)) << ' ' << n(camera.R(r, 1)) << ' ' << n(camera.R(r, 2)) << ' '
        << n(camera.t(r)) << '\n';
  }
  out << "0 0 0 1\n\nintrinsic\n";
  out << n(camera.fx) << " 0 " << n(camera.cx) << '\n';
  out << "0 " << n(camera.fy) << ' ' << n(camera.cy) << '\n';
  out << "0 0 1\n\n";
  out << n(depth_min) << ' ' << n((depth_max - depth_min) / 191.0) << " 192 " << n(depth_max)
      << '\n';
  writeFileAtomically(path, out.str(), "camera file");
}

}  // namespace amhmvs
