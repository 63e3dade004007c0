// Delaunay triangulation of points in the plane (Bowyer-Watson: each point
// is inserted by removing the triangles whose circumcircle holds it and
// joining it to the cavity's boundary). Used for the planar prior
// (planar_prior.h), whose points are pixels: integer coordinates, exact
// orientation and in-circle tests in long double.
#pragma once

#include <array>
#include <vector>

namespace amhmvs {
namespace mvs {

struct Point2i {
  int x, y;
};

// Triangles of `points` as index triples (a, b, c) with (b - a) x (c - a) >
// 0, covering the points' convex hull. Duplicates of a point are left out;
// fewer than three distinct points, or all on one line, give none. Throws
// InputError when the points spread over more than kMaxDelaunaySpan (the
// tests stay exact below it).
constexpr int kMaxDelaunaySpan = 1 << 14;
std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Point2i>& points);

}  // namespace mvs
}  // namespace amhmvs
