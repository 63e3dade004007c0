// Marching cubes (Lorensen and Cline 1987) on one cell of a signed distance
// grid: where the surface (value 0) crosses the cell's edges, and the
// triangles that join those crossings.
//
// The table of the 256 sign cases is derived once from the cube's faces
// rather than typed in: on each face the crossings are joined so that each
// run of negative corners is cut off (on a face whose two diagonal corners are
// negative they stay apart: the rule depends on the face's corners only, so
// two cells that share a face join its crossings alike and the surface has
// no cracks), the face segments are chained into closed loops around the cube
// and each loop is fanned into triangles. Triangles face the positive side
// (free space in a TSDF).
//
// Corner c of a cell sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1)
// voxels; edge e joins corners cellEdgeCorners(e).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace amhmvs {

constexpr int kCellCorners = 8;
constexpr int kCellEdges = 12;

struct CellEdge {
  int corner[2];  // corner[1] = corner[0] + (1 << axis)
  int axis;       // 0, 1, 2: x, y, z
};
const CellEdge& cellEdge(int edge);

// The triangles of one sign case, as edge indices (at most 12 crossings, so
// at most 10 triangles).
struct CellCase {
  int triangle_count = 0;
  std::array<std::array<int8_t, 3>, 10> triangles{};
};
// Case index: bit c set when corner c's value is negative.
const CellCase& cellCase(int case_index);

// Where the surface crosses an edge with values a (at its corner[0]) and b
// of opposite sign: the fraction of the way from corner[0].
inline float crossingFraction(float a, float b) { return a / (a - b); }

}  // namespace amhmvs
