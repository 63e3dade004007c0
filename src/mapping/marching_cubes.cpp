#include "amhmvs_mapping/mapping/marching_cubes.h"

#include <stdexcept>

#include <Eigen/Geometry>

namespace amhmvs {
namespace {

Eigen::Vector3f cornerOffset(int c) { return Eigen::Vector3f(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

std::array<CellEdge, kCellEdges> makeEdges() {
  std::array<CellEdge, kCellEdges> edges{};
  int e = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int c = 0; c < kCellCorners; ++c) {
      if (c & (1 << axis)) continue;
      edges[e++] = CellEdge{{c, c | (1 << axis)}, axis};
    }
  }
  return edges;
}

int edgeBetween(const std::array<CellEdge, kCellEdges>& edges, int a, int b) {
  for (int e = 0; e < kCellEdges; ++e) {
    if ((edges[e].corner[0] == a && edges[e].corner[1] == b) || (edges[e].corner[0] == b && edges[e].corner[1] == a))
      return e;
  }
  throw std::logic_error("marching cubes: corners share no edge");
}

// The six faces, each as its four corners in counter-clockwise order seen
// from outside the cube.
std::array<std::array<int, 4>, 6> makeFaces() {
  std::array<std::array<int, 4>, 6> faces{};
  int f = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      // (0,0) (1,0) (1,1) (0,1) in the face's (u, v): counter-clockwise about +axis.
      std::array<int, 4> face{};
      const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      for (int k = 0; k < 4; ++k) face[k] = (side << axis) | (uv[k][0] << u) | (uv[k][1] << v);
      if (side == 0) std::swap(face[1], face[3]);  // outward normal is -axis
      faces[f++] = face;
    }
  }
  return faces;
}

struct CaseTable {
  std::array<CellEdge, kCellEdges> edges = makeEdges();
  std::array<CellCase, 256> cases{};

  CaseTable() {
    const std::array<std::array<int, 4>, 6> faces = makeFaces();
    for (int index = 0; index < 256; ++index) {
      const auto negative = [index](int c) { return (index >> c) & 1; };
      // next[e]: the crossing that follows crossing e on the loop around the
      // negative corners (-1: e is not crossed).
      int next[kCellEdges];
      for (int& n : next) n = -1;
      for (const std::array<int, 4>& face : faces) {
        for (int k = 0; k < 4; ++k) {
          // A run of negative corners starts after corner k (k positive, k+1 negative) ...
          if (negative(face[k]) || !negative(face[(k + 1) % 4])) continue;
          int end = (k + 1) % 4;
          while (negative(face[(end + 1) % 4])) end = (end + 1) % 4;
          // ... and ends at corner `end`: its segment joins the edge entering the run to the one leaving it.
          next[edgeBetween(edges, face[k], face[(k + 1) % 4])] = edgeBetween(edges, face[end], face[(end + 1) % 4]);
        }
      }
      CellCase& cell = cases[index];
      bool used[kCellEdges] = {};
      for (int start = 0; start < kCellEdges; ++start) {
        if (next[start] < 0 || used[start]) continue;
        std::vector<int> loop;
        for (int e = start; !used[e]; e = next[e]) {
          used[e] = true;
          loop.push_back(e);
        }
        const size_t apex = fanApex(loop);
        for (size_t i = 1; i + 1 < loop.size(); ++i) {
          cell.triangles[cell.triangle_count++] = {static_cast<int8_t>(loop[apex]),
                                                   static_cast<int8_t>(loop[(apex + i) % loop.size()]),
                                                   static_cast<int8_t>(loop[(apex + i + 1) % loop.size()])};
        }
      }
    }
    orientTowardsPositive();
  }

  // Two edges on one face of the cube.
  bool shareFace(int a, int b) const {
    for (int axis = 0; axis < 3; ++axis) {
      if (axis == edges[a].axis || axis == edges[b].axis) continue;
      if (((edges[a].corner[0] >> axis) & 1) == ((edges[b].corner[0] >> axis) & 1)) return true;
    }
    // Perpendicular edges: on a common face when they meet at a corner.
    if (edges[a].axis == edges[b].axis) return false;
    for (int ca : edges[a].corner)
      for (int cb : edges[b].corner)
        if (ca == cb) return true;
    return false;
  }
  // A fan's diagonals from its apex must not lie in a face of the cube: the
  // neighbour across that face could draw the same diagonal, and the two
  // sheets would touch along it. The first apex without such a diagonal.
  size_t fanApex(const std::vector<int>& loop) const {
    const size_t k = loop.size();
    for (size_t apex = 0; apex < k; ++apex) {
      bool clear = true;
      for (size_t i = 2; i + 1 < k && clear; ++i) clear = !shareFace(loop[apex], loop[(apex + i) % k]);
      if (clear) return apex;
    }
    throw std::logic_error("marching cubes: no fan apex without a diagonal in a face");
  }

  // The loops' direction follows the face order; which side that makes the
  // triangles face is settled once, on corner 0 alone negative.
  void orientTowardsPositive() {
    const CellCase& one = cases[1];
    const auto midpoint = [this](int e) {
      return Eigen::Vector3f(0.5f * (cornerOffset(edges[e].corner[0]) + cornerOffset(edges[e].corner[1])));
    };
    const Eigen::Vector3f a = midpoint(one.triangles[0][0]), b = midpoint(one.triangles[0][1]),
                          c = midpoint(one.triangles[0][2]);
    if ((b - a).cross(c - a).dot(Eigen::Vector3f::Ones()) > 0) return;  // faces away from corner 0
    for (CellCase& cell : cases) {
      for (int t = 0; t < cell.triangle_count; ++t) std::swap(cell.triangles[t][1], cell.triangles[t][2]);
    }
  }
};

const CaseTable& table() {
  static const CaseTable instance;
  return instance;
}

}  // namespace

const CellEdge& cellEdge(int edge) { return table().edges[edge]; }
const CellCase& cellCase(int case_index) { return table().cases[case_index]; }

}  // namespace amhmvs
