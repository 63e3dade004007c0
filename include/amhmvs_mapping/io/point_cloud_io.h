// Point clouds, triangle meshes and their files: binary PLY (MeshLab, CloudCompare, Open3D,
// PCL) and binary PCD (PCL), plus a PLY reader for our own and similar files.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace amhmvs {

// Optional attributes are either empty or have one entry per point.
struct PointCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::array<uint8_t, 3>> colors;  // RGB
  std::vector<float> confidence;
  std::vector<uint32_t> counts;  // points merged into each (a voxel map's export); not written to files

  size_t size() const { return points.size(); }
  // Empty when consistent; otherwise which attribute has the wrong length or
  // the first non-finite point.
  std::string validate() const;
};

// Binary little-endian PLY, one "vertex" element: float x y z, then float
// nx ny nz, uchar red green blue and float quality (the confidence) where the
// cloud has them. Throws InputError for an inconsistent cloud, a non-finite
// point, or a file that cannot be written.
void writePly(const std::string& path, const PointCloud& cloud);

// Binary PCD v0.7 (pcl::io::loadPCDFile): FIELDS x y z [rgb] [normal_x
// normal_y normal_z], all 4-byte, rgb packed as PCL does (0x00RRGGBB in the
// bytes of a float, TYPE F). Confidence is not stored. Throws as writePly.
void writePcd(const std::string& path, const PointCloud& cloud);

// Writes PLY or PCD according to the extension (.ply / .pcd, any case);
// throws InputError for other extensions.
void writePointCloud(const std::string& path, const PointCloud& cloud);

// Reads the "vertex" element of an ASCII or binary_little_endian PLY: x y z
// (required), nx ny nz, red green blue (uchar 0..255; float/double 0..1 are
// scaled) and quality / confidence, where all of a group are present. Any
// scalar property type is accepted; other elements are skipped (binary: only
// when they have no list properties). Throws InputError naming the file and
// the problem for other formats, missing x/y/z, list properties in the vertex
// element, truncated data and non-finite coordinates. Allocations are bounded
// by what the file can hold: a vertex count larger than the data (or than
// kMaxPlyVertices) is refused before any memory is reserved.
PointCloud readPly(const std::string& path);

// A triangle mesh: vertices with their attributes, and triangles of vertex
// indices (counter-clockwise seen from the side the normals face).
struct TriangleMesh {
  PointCloud vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  bool empty() const { return triangles.empty(); }
  // Empty when the vertices are consistent and every index is in range.
  std::string validate() const;
};

// Binary little-endian PLY with a "vertex" element (as writePly) and a "face"
// element (uchar count, int indices), written atomically. Throws InputError
// for an invalid mesh or a file that cannot be written.
void writeMeshPly(const std::string& path, const TriangleMesh& mesh);

// The most vertices readPly accepts (2^28: 3 GiB of float positions).
constexpr size_t kMaxPlyVertices = size_t{1} << 28;

}  // namespace amhmvs
