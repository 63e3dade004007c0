// PLY and PCD files: round trips through our reader, the PCD header and size,
// ASCII and foreign PLY files, and clear errors for broken ones.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

PointCloud sampleCloud(bool attributes) {
  PointCloud cloud;
  for (int i = 0; i < 100; ++i) {
    cloud.points.emplace_back(i * 0.5f, -i * 0.25f, 1e3f + i);
    if (!attributes) continue;
    cloud.normals.push_back(Eigen::Vector3f(1, i, -2).normalized());
    cloud.colors.push_back({static_cast<uint8_t>(i), static_cast<uint8_t>(255 - i),
                            static_cast<uint8_t>(i * 2)});
    cloud.confidence.push_back(i / 100.0f);
  }
  return cloud;
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(PointCloudIo, PlyRoundTripKeepsEveryAttributeExactly) {
  test::TempDir dir;
  for (bool attributes : {true, false}) {
    const PointCloud cloud = sampleCloud(attributes);
    writePly(dir.file("c.ply"), cloud);
    const PointCloud back = readPly(dir.file("c.ply"));
    ASSERT_EQ(back.size(), cloud.size());
    EXPECT_EQ(back.points, cloud.points);
    EXPECT_EQ(back.normals, cloud.normals);
    EXPECT_EQ(back.colors, cloud.colors);
    EXPECT_EQ(back.confidence, cloud.confidence);
  }
  const std::string bytes = fileBytes(dir.file("c.ply"));
  EXPECT_EQ(bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
}

TEST(PointCloudIo, MeshPlyHasTheVerticesAndTrianglesAndRefusesBadIndices) {
  test::TempDir dir;
  TriangleMesh mesh;
  mesh.vertices = sampleCloud(true);
  mesh.triangles = {{{0, 1, 2}}, {{2, 1, 3}}};
  writeMeshPly(dir.file("m.ply"), mesh);
  const std::string bytes = fileBytes(dir.file("m.ply"));
  const size_t header_end = bytes.find("end_header\n");
  ASSERT_NE(header_end, std::string::npos);
  const std::string header = bytes.substr(0, header_end);
  EXPECT_NE(header.find("element vertex " + std::to_string(mesh.vertices.size())), std::string::npos);
  EXPECT_NE(header.find("element face 2\nproperty list uchar int vertex_indices"), std::string::npos);
  // The faces are the last 2 x 13 bytes: a count of 3 and three little-endian indices.
  const std::string faces = bytes.substr(bytes.size() - 26);
  EXPECT_EQ(faces[0], 3);
  int32_t index;
  std::memcpy(&index, faces.data() + 13 + 9, 4);
  EXPECT_EQ(index, 3);
  // The vertices read back as a cloud.
  const PointCloud back = readPly(dir.file("m.ply"));
  EXPECT_EQ(back.points, mesh.vertices.points);
  mesh.triangles.push_back({{0, 1, static_cast<uint32_t>(mesh.vertices.size())}});
  try {
    writeMeshPly(dir.file("bad.ply"), mesh);
    FAIL() << "an index past the vertices was written";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("triangle 2 refers to vertex"), std::string::npos);
  }
}

TEST(PointCloudIo, PlyHeaderNamesTheStandardProperties) {
  test::TempDir dir;
  writePly(dir.file("c.ply"), sampleCloud(true));
  const std::string bytes = fileBytes(dir.file("c.ply"));
  const std::string header = bytes.substr(0, bytes.find("end_header\n") + 11);
  EXPECT_NE(header.find("element vertex 100\n"), std::string::npos);
  EXPECT_NE(header.find("property float x\nproperty float y\nproperty float z\n"
                        "property float nx\nproperty float ny\nproperty float nz\n"
                        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                        "property float quality\nend_header\n"),
            std::string::npos)
      << header;
  EXPECT_EQ(bytes.size(), header.size() + 100 * (12 + 12 + 3 + 4));
}

TEST(PointCloudIo, PcdHeaderAndBinarySize) {
  test::TempDir dir;
  writePointCloud(dir.file("c.PCD"), sampleCloud(true));
  const std::string bytes = fileBytes(dir.file("c.PCD"));
  const std::string expected_header =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
      "FIELDS x y z rgb normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4 4\nTYPE F F F F F F F\n"
      "COUNT 1 1 1 1 1 1 1\nWIDTH 100\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 100\n"
      "DATA binary\n";
  ASSERT_EQ(bytes.substr(0, expected_header.size()), expected_header);
  ASSERT_EQ(bytes.size(), expected_header.size() + 100 * 7 * 4);
  // Point 3: x = 1.5, rgb packed 0x00RRGGBB.
  const char* row = bytes.data() + expected_header.size() + 3 * 28;
  float x;
  uint32_t rgb;
  std::memcpy(&x, row, 4);
  std::memcpy(&rgb, row + 12, 4);
  EXPECT_EQ(x, 1.5f);
  EXPECT_EQ(rgb, (3u << 16) | (252u << 8) | 6u);

  writePcd(dir.file("xyz.pcd"), sampleCloud(false));
  const std::string xyz = fileBytes(dir.file("xyz.pcd"));
  EXPECT_NE(xyz.find("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"), std::string::npos);
  EXPECT_EQ(xyz.size(), xyz.find("DATA binary\n") + 12 + 100 * 12);
}

TEST(PointCloudIo, ReadsAsciiAndForeignBinaryPly) {
  test::TempDir dir;
  const std::string ascii = dir.write("a.ply",
                                      "ply\nformat ascii 1.0\ncomment made by hand\n"
                                      "element vertex 2\nproperty double x\nproperty double y\n"
                                      "property double z\nproperty float red\n"
                                      "property float green\nproperty float blue\n"
                                      "element face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n1 2 3 1 0 0.5\n-4 5.5 6e-1 0 1 0\n3 0 1 2\n");
  const PointCloud a = readPly(ascii);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a.points[1], Eigen::Vector3f(-4, 5.5f, 0.6f));
  ASSERT_EQ(a.colors.size(), 2u);
  EXPECT_EQ(a.colors[0], (std::array<uint8_t, 3>{255, 0, 128}));
  EXPECT_TRUE(a.normals.empty());

  // A fixed-size element before the vertices, int16 coordinates.
  std::string bin =
      "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty float f\n"
      "element vertex 1\nproperty short x\nproperty short y\nproperty short z\nend_header\n";
  const char data[] = {0, 0, 0, 0, 1, 0, static_cast<char>(0xfe), static_cast<char>(0xff), 3, 0};
  bin.append(data, sizeof(data));
  const PointCloud b = readPly(dir.write("b.ply", bin));
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b.points[0], Eigen::Vector3f(1, -2, 3));
}

// A vertex count the file cannot hold is refused before anything is
// reserved (it used to end in std::bad_alloc, naming no file).
TEST(PointCloudIo, VertexCountsBeyondTheFileAreRefusedBeforeAllocating) {
  test::TempDir dir;
  const std::string xyz = "property float x\nproperty float y\nproperty float z\nend_header\n";
  EXPECT_INPUT_ERROR(readPly(dir.write("huge.ply", "ply\nformat binary_little_endian 1.0\n"
                                                   "element vertex 4000000000\n" + xyz)),
                     "huge.ply", "vertex count 4000000000 exceeds the reader's maximum");
  EXPECT_INPUT_ERROR(readPly(dir.write("many.ply", "ply\nformat ascii 1.0\n"
                                                   "element vertex 100000000\n" + xyz + "1 2 3\n")),
                     "many.ply", "6 bytes of ASCII data cannot hold 100000000 vertices");
}

// An element of 2^62 four-byte rows before the vertices: count * row size
// wraps to 0 in 64 bits, which used to read the vertices from the wrong offset.
TEST(PointCloudIo, ElementSizesThatOverflowAreRefused) {
  test::TempDir dir;
  std::string bin =
      "ply\nformat binary_little_endian 1.0\nelement face 4611686018427387904\n"
      "property int f\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "end_header\n";
  bin.append(12, '\0');
  EXPECT_INPUT_ERROR(readPly(dir.write("wrap.ply", bin)), "wrap.ply",
                     "element 'face' claims 4611686018427387904 rows, more than the file holds");
}

TEST(PointCloudIo, BrokenFilesAndCloudsAreRefused) {
  test::TempDir dir;
  EXPECT_INPUT_ERROR(readPly(dir.file("missing.ply")), "missing.ply", "cannot open");
  EXPECT_INPUT_ERROR(readPly(dir.write("n.ply", "not a ply")), "n.ply", "not a PLY");
  EXPECT_INPUT_ERROR(
      readPly(dir.write("be.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 0\n"
                                  "property float x\nend_header\n")),
      "be.ply", "binary_big_endian");
  EXPECT_INPUT_ERROR(readPly(dir.write("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                                                  "property float x\nproperty float y\n"
                                                  "end_header\n1 2\n")),
                     "noz.ply", "'z'");
  EXPECT_INPUT_ERROR(readPly(dir.write("short.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"
                                                    "property float x\nproperty float y\n"
                                                    "property float z\nend_header\n1 2 3\n")),
                     "short.ply", "truncated");
  EXPECT_INPUT_ERROR(readPly(dir.write("nan.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                                                  "property float x\nproperty float y\n"
                                                  "property float z\nend_header\nnan 2 3\n")),
                     "nan.ply", "non-finite");
  std::string truncated = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
                          "property float x\nproperty float y\nproperty float z\nend_header\n";
  truncated.append(20, '\0');
  EXPECT_INPUT_ERROR(readPly(dir.write("t.ply", truncated)), "t.ply", "truncated");

  PointCloud bad = sampleCloud(true);
  bad.points[7].y() = std::numeric_limits<float>::infinity();
  EXPECT_INPUT_ERROR(writePly(dir.file("bad.ply"), bad), "bad.ply", "point 7 is not finite");
  bad = sampleCloud(true);
  bad.colors.pop_back();
  EXPECT_INPUT_ERROR(writePcd(dir.file("bad.pcd"), bad), "bad.pcd", "99 colours for 100");
  EXPECT_INPUT_ERROR(writePointCloud(dir.file("c.xyz"), sampleCloud(false)), "c.xyz",
                     "extension");
  EXPECT_INPUT_ERROR(writePly(dir.file("no/such/dir/c.ply"), sampleCloud(false)), "c.ply",
                     "cannot open");
}

}  // namespace
}  // namespace amhmvs
