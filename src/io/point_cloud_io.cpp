// PLY and PCD files of point clouds (include/amhmvs_mapping/io/point_cloud_io.h).
// It lives in src/mapping because the core's CMake list picks up that folder.
#include "amhmvs_mapping/io/point_cloud_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <sstream>

#include "file_util.h"
#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/atomic_file.h"

namespace amhmvs {

std::string PointCloud::validate() const {
  const size_t n = points.size();
  std::ostringstream why;
  if (!normals.empty() && normals.size() != n) {
    why << normals.size() << " normals for " << n << " points";
  } else if (!colors.empty() && colors.size() != n) {
    why << colors.size() << " colours for " << n << " points";
  } else if (!confidence.empty() && confidence.size() != n) {
    why << confidence.size() << " confidences for " << n << " points";
  } else if (!counts.empty() && counts.size() != n) {
    why << counts.size() << " counts for " << n << " points";
  } else {
    for (size_t i = 0; i < n; ++i) {
      if (!points[i].allFinite()) {
        why << "point " << i << " is not finite";
        break;
      }
    }
  }
  return why.str();
}

namespace {

// Appends a 4-byte value in little-endian byte order whatever the host.
void appendLe32(std::string* out, const void* value) {
  char bytes[4];
  std::memcpy(bytes, value, 4);
  if (!internal::isLittleEndianHost()) std::reverse(bytes, bytes + 4);
  out->append(bytes, 4);
}

void appendFloat(std::string* out, float value) { appendLe32(out, &value); }

void checkCloud(const std::string& path, const PointCloud& cloud) {
  const std::string why = cloud.validate();
  if (!why.empty()) throw InputError(path + ": cannot write point cloud: " + why);
}

std::string lowerExtension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

namespace {

// The vertex element of a PLY file: its header lines and its data.
void plyVertexElement(const PointCloud& cloud, std::ostringstream* header, std::string* data) {
  const bool normals = !cloud.normals.empty(), colors = !cloud.colors.empty(),
             quality = !cloud.confidence.empty();
  *header << "element vertex " << cloud.size() << "\n"
          << "property float x\nproperty float y\nproperty float z\n";
  if (normals) *header << "property float nx\nproperty float ny\nproperty float nz\n";
  if (colors) *header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (quality) *header << "property float quality\n";
  data->reserve(data->size() + cloud.size() * (12 + 12 * normals + 3 * colors + 4 * quality));
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) appendFloat(data, cloud.points[i][k]);
    if (normals) {
      for (int k = 0; k < 3; ++k) appendFloat(data, cloud.normals[i][k]);
    }
    if (colors) data->append(reinterpret_cast<const char*>(cloud.colors[i].data()), 3);
    if (quality) appendFloat(data, cloud.confidence[i]);
  }
}

}  // namespace

void writePly(const std::string& path, const PointCloud& cloud) {
  checkCloud(path, cloud);
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment amhmvs_mapping fused point cloud\n";
  std::string data;
  plyVertexElement(cloud, &header, &data);
  header << "end_header\n";
  writeFileAtomically(path, header.str() + data, "PLY point cloud");
}

std::string TriangleMesh::validate() const {
  const std::string problem = vertices.validate();
  if (!problem.empty()) return problem;
  for (size_t t = 0; t < triangles.size(); ++t) {
    for (uint32_t index : triangles[t]) {
      if (index >= vertices.size())
        return "triangle " + std::to_string(t) + " refers to vertex " + std::to_string(index) + " of " +
               std::to_string(vertices.size());
    }
  }
  return "";
}

void writeMeshPly(const std::string& path, const TriangleMesh& mesh) {
  const std::string problem = mesh.validate();
  if (!problem.empty()) throw InputError(path + ": mesh not written: " + problem);
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment amhmvs_mapping surface mesh\n";
  std::string data;
  plyVertexElement(mesh.vertices, &header, &data);
  header << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  data.reserve(data.size() + mesh.triangles.size() * 13);
  for (const std::array<uint32_t, 3>& triangle : mesh.triangles) {
    data.push_back(3);
    for (uint32_t index : triangle) appendLe32(&data, &index);
  }
  writeFileAtomically(path, header.str() + data, "PLY mesh");
}

void writePcd(const std::string& path, const PointCloud& cloud) {
  checkCloud(path, cloud);
  const bool normals = !cloud.normals.empty(), colors = !cloud.colors.empty();
  const int fields = 3 + colors + 3 * normals;
  std::ostringstream header;
  header << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z"
         << (colors ? " rgb" : "") << (normals ? " normal_x normal_y normal_z" : "") << "\n";
  header << "SIZE";
  for (int i = 0; i < fields; ++i) header << " 4";
  header << "\nTYPE";
  for (int i = 0; i < fields; ++i) header << " F";
  header << "\nCOUNT";
  for (int i = 0; i < fields; ++i) header << " 1";
  header << "\nWIDTH " << cloud.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS "
         << cloud.size() << "\nDATA binary\n";
  std::string bytes = header.str();
  bytes.reserve(bytes.size() + cloud.size() * 4 * fields);
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) appendFloat(&bytes, cloud.points[i][k]);
    if (colors) {
      const auto& c = cloud.colors[i];
      const uint32_t rgb = (uint32_t{c[0]} << 16) | (uint32_t{c[1]} << 8) | c[2];
      appendLe32(&bytes, &rgb);
    }
    if (normals) {
      for (int k = 0; k < 3; ++k) appendFloat(&bytes, cloud.normals[i][k]);
    }
  }
  writeFileAtomically(path, bytes, "PCD point cloud");
}

void writePointCloud(const std::string& path, const PointCloud& cloud) {
  const std::string ext = lowerExtension(path);
  if (ext == "ply") return writePly(path, cloud);
  if (ext == "pcd") return writePcd(path, cloud);
  throw InputError(path + ": unknown point cloud extension (use .ply or .pcd)");
}

// ---------------------------------------------------------------------------
// PLY reader

namespace {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool parsePlyType(const std::string& name, PlyType* type, int* size) {
  static const struct {
    const char* name;
    PlyType type;
    int size;
  } kTypes[] = {{"char", PlyType::kInt8, 1},     {"int8", PlyType::kInt8, 1},
                {"uchar", PlyType::kUint8, 1},   {"uint8", PlyType::kUint8, 1},
                {"short", PlyType::kInt16, 2},   {"int16", PlyType::kInt16, 2},
                {"ushort", PlyType::kUint16, 2}, {"uint16", PlyType::kUint16, 2},
                {"int", PlyType::kInt32, 4},     {"int32", PlyType::kInt32, 4},
                {"uint", PlyType::kUint32, 4},   {"uint32", PlyType::kUint32, 4},
                {"float", PlyType::kFloat32, 4}, {"float32", PlyType::kFloat32, 4},
                {"double", PlyType::kFloat64, 8}, {"float64", PlyType::kFloat64, 8}};
  for (const auto& t : kTypes) {
    if (name == t.name) {
      *type = t.type;
      *size = t.size;
      return true;
    }
  }
  return false;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  int size = 4;
  bool is_list = false;
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;
  size_t rowBytes() const {
    size_t n = 0;
    for (const PlyProperty& p : properties) n += p.size;
    return n;
  }
};

double decodeLe(const char* data, PlyType type) {
  unsigned char b[8];
  const int size = type == PlyType::kFloat64 ? 8
                   : (type == PlyType::kInt32 || type == PlyType::kUint32 ||
                      type == PlyType::kFloat32)
                       ? 4
                   : (type == PlyType::kInt16 || type == PlyType::kUint16) ? 2
                                                                          : 1;
  std::memcpy(b, data, size);
  if (!internal::isLittleEndianHost()) std::reverse(b, b + size);
  switch (type) {
    case PlyType::kInt8: { int8_t v; std::memcpy(&v, b, 1); return v; }
    case PlyType::kUint8: return b[0];
    case PlyType::kInt16: { int16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::kUint16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::kInt32: { int32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::kUint32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::kFloat32: { float v; std::memcpy(&v, b, 4); return v; }
    case PlyType::kFloat64: { double v; std::memcpy(&v, b, 8); return v; }
  }
  return 0;
}

// Index of each attribute's properties in the vertex element, -1 if absent.
struct VertexLayout {
  int xyz[3] = {-1, -1, -1}, normal[3] = {-1, -1, -1}, color[3] = {-1, -1, -1};
  int quality = -1;
  bool float_color = false;
};

VertexLayout vertexLayout(const PlyElement& vertex, const std::string& path) {
  VertexLayout layout;
  auto find = [&](std::initializer_list<const char*> names) {
    for (size_t i = 0; i < vertex.properties.size(); ++i) {
      for (const char* n : names) {
        if (vertex.properties[i].name == n) return static_cast<int>(i);
      }
    }
    return -1;
  };
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    layout.xyz[k] = find({axes[k]});
    if (layout.xyz[k] < 0) {
      throw InputError(path + ": vertex element has no '" + axes[k] + "' property");
    }
  }
  layout.normal[0] = find({"nx", "normal_x"});
  layout.normal[1] = find({"ny", "normal_y"});
  layout.normal[2] = find({"nz", "normal_z"});
  layout.color[0] = find({"red", "r", "diffuse_red"});
  layout.color[1] = find({"green", "g", "diffuse_green"});
  layout.color[2] = find({"blue", "b", "diffuse_blue"});
  layout.quality = find({"quality", "confidence", "scalar_confidence"});
  for (int* group : {layout.normal, layout.color}) {
    if (group[0] < 0 || group[1] < 0 || group[2] < 0) group[0] = group[1] = group[2] = -1;
  }
  if (layout.color[0] >= 0) {
    const PlyType t = vertex.properties[layout.color[0]].type;
    layout.float_color = t == PlyType::kFloat32 || t == PlyType::kFloat64;
  }
  for (const PlyProperty& p : vertex.properties) {
    if (p.is_list) throw InputError(path + ": list property '" + p.name + "' in vertex element");
  }
  return layout;
}

void addVertex(const std::vector<double>& v, const VertexLayout& layout, const std::string& path,
               size_t index, PointCloud* cloud) {
  const Eigen::Vector3f p(v[layout.xyz[0]], v[layout.xyz[1]], v[layout.xyz[2]]);
  if (!p.allFinite()) {
    throw InputError(path + ": vertex " + std::to_string(index) + " has non-finite coordinates");
  }
  cloud->points.push_back(p);
  if (layout.normal[0] >= 0) {
    cloud->normals.emplace_back(v[layout.normal[0]], v[layout.normal[1]], v[layout.normal[2]]);
  }
  if (layout.color[0] >= 0) {
    std::array<uint8_t, 3> c;
    for (int k = 0; k < 3; ++k) {
      double value = v[layout.color[k]];
      if (layout.float_color) value *= 255.0;
      c[k] = static_cast<uint8_t>(std::clamp(std::isfinite(value) ? std::round(value) : 0.0,
                                             0.0, 255.0));
    }
    cloud->colors.push_back(c);
  }
  if (layout.quality >= 0) cloud->confidence.push_back(static_cast<float>(v[layout.quality]));
}

}  // namespace

PointCloud readPly(const std::string& path) {
  const std::string bytes = internal::readFileBytes(path);
  const size_t header_end = bytes.find("end_header");
  if (bytes.compare(0, 3, "ply") != 0 || header_end == std::string::npos) {
    throw InputError(path + ": not a PLY file (no 'ply' magic or no 'end_header')");
  }
  size_t data_start = bytes.find('\n', header_end);
  if (data_start == std::string::npos) throw InputError(path + ": truncated PLY header");
  ++data_start;

  std::istringstream header(bytes.substr(0, header_end));
  std::string line, format;
  std::vector<PlyElement> elements;
  int line_number = 0;
  while (std::getline(header, line)) {
    ++line_number;
    const std::vector<std::string> tokens = internal::splitWhitespace(line);
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info" ||
        tokens[0] == "ply") {
      continue;
    }
    const std::string where = path + ": header line " + std::to_string(line_number) + " ('" +
                              internal::excerpt(line) + "')";
    long long count;
    if (tokens[0] == "format" && tokens.size() >= 2) {
      format = tokens[1];
    } else if (tokens[0] == "element" && tokens.size() == 3 &&
               internal::parseInt(tokens[2], &count) && count >= 0) {
      elements.push_back({tokens[1], static_cast<size_t>(count), {}});
    } else if (tokens[0] == "property" && !elements.empty()) {
      PlyProperty p;
      if (tokens.size() == 5 && tokens[1] == "list") {
        p.is_list = true;
        p.name = tokens[4];
      } else if (tokens.size() == 3 && parsePlyType(tokens[1], &p.type, &p.size)) {
        p.name = tokens[2];
      } else {
        throw InputError(where + ": malformed property");
      }
      elements.back().properties.push_back(p);
    } else {
      throw InputError(where + ": unexpected header line");
    }
  }
  if (format != "ascii" && format != "binary_little_endian") {
    throw InputError(path + ": unsupported PLY format '" + format +
                     "' (ascii and binary_little_endian are read)");
  }
  size_t vertex_index = elements.size();
  for (size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].name == "vertex") {
      vertex_index = i;
      break;
    }
  }
  if (vertex_index == elements.size()) throw InputError(path + ": no vertex element");
  const PlyElement& vertex = elements[vertex_index];
  const VertexLayout layout = vertexLayout(vertex, path);

  if (vertex.count > kMaxPlyVertices) {
    throw InputError(path + ": vertex count " + std::to_string(vertex.count) +
                     " exceeds the reader's maximum of " + std::to_string(kMaxPlyVertices));
  }
  PointCloud cloud;
  std::vector<double> values(vertex.properties.size());
  if (format == "ascii") {
    // Each vertex line holds at least one character and one separator per
    // property: a count the file cannot hold is refused before allocating.
    const size_t body_bytes = bytes.size() - data_start;
    if (vertex.count > body_bytes / (2 * vertex.properties.size())) {
      throw InputError(path + ": truncated: " + std::to_string(body_bytes) +
                       " bytes of ASCII data cannot hold " + std::to_string(vertex.count) +
                       " vertices");
    }
    cloud.points.reserve(vertex.count);
    std::istringstream body(bytes.substr(data_start));
    size_t skip = 0;  // lines of the elements before the vertex element
    for (size_t i = 0; i < vertex_index; ++i) {
      if (!internal::checkedAdd(skip, elements[i].count, &skip)) {
        throw InputError(path + ": element counts before the vertices overflow");
      }
    }
    for (size_t i = 0; i < skip && std::getline(body, line); ++i) {
    }
    for (size_t i = 0; i < vertex.count; ++i) {
      if (!std::getline(body, line)) {
        throw InputError(path + ": truncated: " + std::to_string(i) + " of " +
                         std::to_string(vertex.count) + " vertices");
      }
      std::istringstream fields(line);
      for (double& v : values) {
        std::string token;
        if (!(fields >> token)) {
          throw InputError(path + ": vertex " + std::to_string(i) + ": too few values");
        }
        // Non-finite values are accepted here; x/y/z are checked in addVertex.
        char* end = nullptr;
        v = std::strtod(token.c_str(), &end);
        if (*end != '\0') {
          throw InputError(path + ": vertex " + std::to_string(i) + ": bad number '" + token +
                           "'");
        }
      }
      addVertex(values, layout, path, i, &cloud);
    }
    return cloud;
  }

  size_t offset = data_start;
  for (size_t i = 0; i < vertex_index; ++i) {
    for (const PlyProperty& p : elements[i].properties) {
      if (p.is_list) {
        throw InputError(path + ": element '" + elements[i].name +
                         "' before the vertices has list properties (not supported)");
      }
    }
    size_t element_bytes = 0;
    if (!internal::checkedMultiply(elements[i].count, elements[i].rowBytes(), &element_bytes) ||
        !internal::checkedAdd(offset, element_bytes, &offset) || offset > bytes.size()) {
      throw InputError(path + ": truncated: element '" + elements[i].name + "' claims " +
                       std::to_string(elements[i].count) + " rows, more than the file holds");
    }
  }
  const size_t row = vertex.rowBytes();
  if ((bytes.size() - offset) / row < vertex.count) {
    throw InputError(path + ": truncated: binary data holds fewer than " +
                     std::to_string(vertex.count) + " vertices");
  }
  cloud.points.reserve(vertex.count);
  for (size_t i = 0; i < vertex.count; ++i) {
    const char* data = bytes.data() + offset + i * row;
    for (size_t k = 0; k < vertex.properties.size(); ++k) {
      values[k] = decodeLe(data, vertex.properties[k].type);
      data += vertex.properties[k].size;
    }
    addVertex(values, layout, path, i, &cloud);
  }
  return cloud;
}

}  // namespace amhmvs
