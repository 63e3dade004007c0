#include "amhmvs_mapping/mvs/delaunay.h"

#include <algorithm>
#include <string>
#include <unordered_map>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace mvs {
namespace {

using Real = long double;  // 64-bit mantissa: the in-circle terms below kMaxDelaunaySpan are exact

// The vertex at infinity: the triangles that hold it ("ghosts") stand for
// the outside of the hull, one per hull edge, so that points beyond the hull
// are inserted as points inside are.
constexpr int kInfinite = -1;

struct Triangle {
  int v[3];     // positively oriented; a ghost has kInfinite at one corner
  int next[3];  // the neighbour across the edge opposite v[i]
  bool alive;
};

Real orientation(const Point2i& a, const Point2i& b, const Point2i& c) {
  return static_cast<Real>(b.x - a.x) * (c.y - a.y) - static_cast<Real>(b.y - a.y) * (c.x - a.x);
}

// > 0 when d lies inside the circle through a, b, c (positively oriented).
Real inCircle(const Point2i& a, const Point2i& b, const Point2i& c, const Point2i& d) {
  const Real ax = a.x - d.x, ay = a.y - d.y, bx = b.x - d.x, by = b.y - d.y, cx = c.x - d.x, cy = c.y - d.y;
  const Real a2 = ax * ax + ay * ay, b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  return ax * (by * c2 - b2 * cy) - ay * (bx * c2 - b2 * cx) + a2 * (bx * cy - by * cx);
}

class Triangulation {
 public:
  explicit Triangulation(const std::vector<Point2i>& vertices) : vertices_(vertices) {}

  // The positively oriented real triangle (a, b, c) and its three ghosts.
  void start(int a, int b, int c) {
    triangles_.push_back({{a, b, c}, {2, 3, 1}, true});
    // Across the edge (u, w) of the real triangle: the ghost (w, u, inf).
    triangles_.push_back({{b, a, kInfinite}, {3, 2, 0}, true});  // across (a, b)
    triangles_.push_back({{c, b, kInfinite}, {1, 3, 0}, true});  // across (b, c)
    triangles_.push_back({{a, c, kInfinite}, {2, 1, 0}, true});  // across (c, a)
    last_ = 0;
  }

  void insert(int p) {
    const int first = locate(p);
    if (first < 0) return;  // on a vertex already
    cavity_.clear();
    triangles_[first].alive = false;
    cavity_.push_back(first);
    for (size_t k = 0; k < cavity_.size(); ++k) {
      const Triangle& t = triangles_[cavity_[k]];
      for (int i = 0; i < 3; ++i) {
        const int n = t.next[i];
        if (!triangles_[n].alive || !inCircumcircle(triangles_[n], p)) continue;
        triangles_[n].alive = false;
        cavity_.push_back(n);
      }
    }
    // Join p to every boundary edge (a, b) of the cavity: (a, b, p), a ghost
    // where a or b is the vertex at infinity.
    created_.clear();
    for (int dead : cavity_) {
      for (int i = 0; i < 3; ++i) {
        const Triangle t = triangles_[dead];
        const int outside = t.next[i];
        if (!triangles_[outside].alive) continue;  // inside the cavity
        const int a = t.v[(i + 1) % 3], b = t.v[(i + 2) % 3];
        const int id = static_cast<int>(triangles_.size());
        triangles_.push_back({{a, b, p}, {-1, -1, outside}, true});
        Triangle& o = triangles_[outside];
        for (int j = 0; j < 3; ++j)
          if (o.next[j] == dead) o.next[j] = id;
        created_.push_back(id);
      }
    }
    // Neighbours among the new triangles: (a, b, p) meets (b, c, p) across
    // (b, p) and (z, a, p) across (p, a).
    starting_at_.clear();
    for (int id : created_) starting_at_[triangles_[id].v[0]] = id;
    for (int id : created_) triangles_[id].next[0] = starting_at_.at(triangles_[id].v[1]);
    for (int id : created_) triangles_[triangles_[id].next[0]].next[1] = id;
    for (int id : created_)
      if (!isGhost(triangles_[id])) last_ = id;
  }

  std::vector<std::array<int, 3>> triangles() const {
    std::vector<std::array<int, 3>> out;
    for (const Triangle& t : triangles_)
      if (t.alive && !isGhost(t)) out.push_back({t.v[0], t.v[1], t.v[2]});
    return out;
  }

 private:
  static bool isGhost(const Triangle& t) {
    return t.v[0] == kInfinite || t.v[1] == kInfinite || t.v[2] == kInfinite;
  }

  // A real triangle's circumcircle; a ghost's "circle" is the open half-plane
  // beyond its hull edge, with the open edge itself.
  bool inCircumcircle(const Triangle& t, int p) const {
    const Point2i& q = vertices_[p];
    for (int k = 0; k < 3; ++k) {
      if (t.v[k] != kInfinite) continue;
      const Point2i& u = vertices_[t.v[(k + 1) % 3]];
      const Point2i& w = vertices_[t.v[(k + 2) % 3]];
      const Real side = orientation(u, w, q);
      if (side != 0) return side > 0;
      const long dot = static_cast<long>(q.x - u.x) * (w.x - u.x) + static_cast<long>(q.y - u.y) * (w.y - u.y);
      const long length2 = static_cast<long>(w.x - u.x) * (w.x - u.x) + static_cast<long>(w.y - u.y) * (w.y - u.y);
      return dot > 0 && dot < length2;
    }
    return inCircle(vertices_[t.v[0]], vertices_[t.v[1]], vertices_[t.v[2]], q) > 0;
  }

  // A live triangle that holds p (a ghost when p is outside the hull), by
  // walking from the last real triangle made; -1 when p is a vertex.
  int locate(int p) {
    int t = last_;
    const Point2i& q = vertices_[p];
    for (size_t steps = 0; steps < 4 * triangles_.size() + 8; ++steps) {
      const Triangle& tri = triangles_[t];
      if (isGhost(tri)) return t;  // stepped across a hull edge: p lies beyond it
      int across = -1;
      for (int i = 0; i < 3; ++i) {
        if (orientation(vertices_[tri.v[(i + 1) % 3]], vertices_[tri.v[(i + 2) % 3]], q) < 0) {
          across = i;
          break;
        }
      }
      if (across < 0) {
        for (int i = 0; i < 3; ++i)
          if (vertices_[tri.v[i]].x == q.x && vertices_[tri.v[i]].y == q.y) return -1;
        return t;
      }
      t = tri.next[across];
    }
    throw InputError("delaunay: a point could not be located (internal error)");
  }

  const std::vector<Point2i>& vertices_;
  std::vector<Triangle> triangles_;
  std::vector<int> cavity_, created_;
  std::unordered_map<int, int> starting_at_;
  int last_ = 0;
};

}  // namespace

std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Point2i>& points) {
  if (points.size() < 3) return {};
  int min_x = points[0].x, max_x = points[0].x, min_y = points[0].y, max_y = points[0].y;
  for (const Point2i& p : points) {
    min_x = std::min(min_x, p.x), max_x = std::max(max_x, p.x);
    min_y = std::min(min_y, p.y), max_y = std::max(max_y, p.y);
  }
  const long span = std::max(static_cast<long>(max_x) - min_x, static_cast<long>(max_y) - min_y);
  if (span > kMaxDelaunaySpan)
    throw InputError("delaunay: the points spread over " + std::to_string(span) + " > " +
                     std::to_string(kMaxDelaunaySpan));
  // Row bands with alternating direction: each point lands near the last.
  std::vector<int> order(points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  const int band = static_cast<int>(std::max(1L, span / 64));
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const Point2i& p = points[a];
    const Point2i& q = points[b];
    const int rp = (p.y - min_y) / band, rq = (q.y - min_y) / band;
    if (rp != rq) return rp < rq;
    if (p.x != q.x) return (rp % 2 == 0) ? p.x < q.x : p.x > q.x;
    return p.y < q.y;
  });
  // The first triangle: the first point, the next distinct one, the next
  // off their line.
  const int a = order[0];
  size_t i = 1;
  while (i < order.size() && points[order[i]].x == points[a].x && points[order[i]].y == points[a].y) ++i;
  if (i == order.size()) return {};
  const int b = order[i];
  size_t j = i + 1;
  while (j < order.size() && orientation(points[a], points[b], points[order[j]]) == 0) ++j;
  if (j == order.size()) return {};
  const int c = order[j];
  Triangulation triangulation(points);
  if (orientation(points[a], points[b], points[c]) > 0) {
    triangulation.start(a, b, c);
  } else {
    triangulation.start(a, c, b);
  }
  for (size_t k = 1; k < order.size(); ++k)
    if (k != i && k != j) triangulation.insert(order[k]);
  return triangulation.triangles();
}

}  // namespace mvs
}  // namespace amhmvs
