#include "amhmvs_mapping/simulation/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Hits closer than this ray parameter are ignored (camera rays: z-depth, m).
constexpr double kMinRayParameter = 1e-6;

// ---------------------------------------------------------------------------
// Deterministic hashing and random numbers (no std distributions: their
// output is not specified across standard libraries).

inline uint32_t mix32(uint32_t h) {
  h ^= h >> 16;
  h *= 0x85EBCA6Bu;
  h ^= h >> 13;
  h *= 0xC2B2AE35u;
  h ^= h >> 16;
  return h;
}

inline uint32_t hashCell(uint32_t seed, int64_t ix, int64_t iy, int64_t iz) {
  return mix32(seed ^ (static_cast<uint32_t>(ix) * 0x8DA6B343u) ^
               (static_cast<uint32_t>(iy) * 0xD8163841u) ^
               (static_cast<uint32_t>(iz) * 0xCB1AB31Fu));
}

inline double toUnit(uint32_t h) { return h * (1.0 / 4294967296.0); }

inline uint32_t deriveSeed(uint32_t seed, uint32_t salt) {
  return mix32(seed ^ mix32(salt * 0x9E3779B9u + 0x632BE5ABu));
}

class SplitMix {
 public:
  explicit SplitMix(uint64_t seed) : state_(seed * 0x9E3779B97F4A7C15ull + 0x1234567ull) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  uint32_t next32() { return static_cast<uint32_t>(next() >> 32); }

 private:
  uint64_t state_;
};

// ---------------------------------------------------------------------------
// Procedural texture. Coordinates `p` are in metres (2D for planes, 3D for
// spheres; unused components are 0).

inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

// Value noise in [0, 1) with C2 quintic interpolation, lattice spacing 1,
// for `count` seeds at once (same point, independent lattices); dims 2 or 3.
void valueNoise(const double p[3], int dims, const uint32_t* seeds, int count, double* out) {
  const double fx = std::floor(p[0]), fy = std::floor(p[1]);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double wx = fade(p[0] - fx), wy = fade(p[1] - fy);
  const double w00 = (1 - wx) * (1 - wy), w10 = wx * (1 - wy), w01 = (1 - wx) * wy,
               w11 = wx * wy;
  if (dims == 2) {
    for (int s = 0; s < count; ++s) {
      const uint32_t k = seeds[s];
      out[s] = w00 * toUnit(hashCell(k, ix, iy, 0)) + w10 * toUnit(hashCell(k, ix + 1, iy, 0)) +
               w01 * toUnit(hashCell(k, ix, iy + 1, 0)) +
               w11 * toUnit(hashCell(k, ix + 1, iy + 1, 0));
    }
    return;
  }
  const double fz = std::floor(p[2]);
  const int64_t iz = static_cast<int64_t>(fz);
  const double wz = fade(p[2] - fz);
  for (int s = 0; s < count; ++s) {
    const uint32_t k = seeds[s];
    double layer[2];
    for (int l = 0; l < 2; ++l) {
      layer[l] = w00 * toUnit(hashCell(k, ix, iy, iz + l)) +
                 w10 * toUnit(hashCell(k, ix + 1, iy, iz + l)) +
                 w01 * toUnit(hashCell(k, ix, iy + 1, iz + l)) +
                 w11 * toUnit(hashCell(k, ix + 1, iy + 1, iz + l));
    }
    out[s] = (1 - wz) * layer[0] + wz * layer[1];
  }
}

inline double valueNoise(const double p[3], int dims, uint32_t seed) {
  double out;
  valueNoise(p, dims, &seed, 1, &out);
  return out;
}

inline double smoothstep(double e0, double e1, double x) {
  const double t = std::min(1.0, std::max(0.0, (x - e0) / (e1 - e0)));
  return t * t * (3.0 - 2.0 * t);
}

// Lattice coordinates of octave `octave`: p scaled by `factor` and rotated
// in the first two axes by a per-octave angle (hides the lattice directions).
inline void octaveCoords(const double p[3], double factor, int octave, double out[3]) {
  static const double kCos[4] = {0.8775825619, 0.4535961214, -0.3232895669, 0.9689124217};
  static const double kSin[4] = {0.4794255386, 0.8912073601, 0.9463000877, 0.2474039593};
  out[0] = factor * (kCos[octave] * p[0] - kSin[octave] * p[1]) + 17.31 * octave;
  out[1] = factor * (kSin[octave] * p[0] + kCos[octave] * p[1]) - 9.77 * octave;
  out[2] = factor * p[2] + 5.13 * octave;
}

// A surface's texture, with everything derived from its seed precomputed.
struct Texture {
  uint32_t octave_seeds[3];
  uint32_t tint_seeds[3];
  uint32_t blob_seed;
  double chroma[3];  // per-surface base hue, zero mean over channels
  double inv_scale;
  double contrast;

  Texture(uint32_t seed, double scale, double contrast_) {
    for (int k = 0; k < 3; ++k) {
      octave_seeds[k] = deriveSeed(seed, 1 + k);
      tint_seeds[k] = deriveSeed(seed, 10 + k);
    }
    blob_seed = deriveSeed(seed, 20);
    double base[3], mean = 0;
    for (int c = 0; c < 3; ++c) {
      base[c] = toUnit(deriveSeed(seed, 30 + c));
      mean += base[c] / 3;
    }
    for (int c = 0; c < 3; ++c) chroma[c] = base[c] - mean;
    inv_scale = 1.0 / scale;
    contrast = contrast_;
  }

  // RGB radiance in (30, 225) at surface coordinates p (metres), 2 or 3 dims.
  Eigen::Vector3d color(const double p_metres[3], int dims) const {
    const double p[3] = {p_metres[0] * inv_scale, p_metres[1] * inv_scale,
                         p_metres[2] * inv_scale};
    double q[3];

    // Luminance: three octaves, lattice spacings 4, 2 and 1 x scale.
    octaveCoords(p, 0.25, 0, q);
    double lum = 0.20 * valueNoise(q, dims, octave_seeds[0]);
    octaveCoords(p, 0.5, 1, q);
    lum += 0.35 * valueNoise(q, dims, octave_seeds[1]);
    octaveCoords(p, 1.0, 2, q);
    lum += 0.45 * valueNoise(q, dims, octave_seeds[2]);
    lum = 0.5 + 2.0 * (lum - 0.5);

    // Colour: the muted base hue plus a slowly varying tint.
    double tint[3], v[3];
    octaveCoords(p, 1.0 / 3.0, 3, q);
    valueNoise(q, dims, tint_seeds, 3, tint);
    for (int c = 0; c < 3; ++c) v[c] = lum + 0.35 * chroma[c] + 0.2 * (tint[c] - 0.5);

    // Soft-edged blobs: at most one per cell of 2.5 x scale, fully inside it.
    const double cell = 2.5;
    int64_t ic[3] = {0, 0, 0};
    double local[3] = {0, 0, 0};
    for (int k = 0; k < dims; ++k) {
      const double f = std::floor(p[k] / cell);
      ic[k] = static_cast<int64_t>(f);
      local[k] = p[k] - f * cell;
    }
    const uint32_t h0 = hashCell(blob_seed, ic[0], ic[1], ic[2]);
    if (toUnit(h0) < 0.5) {
      uint32_t h = h0;
      auto next = [&h]() {
        h = mix32(h + 0x9E3779B9u);
        return toUnit(h);
      };
      const double radius = cell * (0.12 + 0.22 * next());
      double d2 = 0;
      for (int k = 0; k < dims; ++k) {
        const double centre = radius + (cell - 2 * radius) * next();
        d2 += (local[k] - centre) * (local[k] - centre);
      }
      if (d2 < radius * radius) {
        const double mask = 1.0 - smoothstep(radius * 0.7, radius, std::sqrt(d2));
        const double level = next() < 0.5 ? 0.0 : 1.0;
        for (int c = 0; c < 3; ++c) {
          const double colour = level + 0.3 * chroma[c] + 0.2 * (next() - 0.5);
          v[c] += mask * (colour - v[c]);
        }
      }
    }

    Eigen::Vector3d rgb;
    for (int c = 0; c < 3; ++c) {
      // Smooth saturation into (-0.5, 0.5), slope 1 at v = 0.5.
      const double t = 2.0 * (v[c] - 0.5);
      const double y = 0.5 * t / std::sqrt(1.0 + t * t);
      rgb[c] = 127.5 + contrast * 195.0 * y;
    }
    return rgb;
  }
};

// ---------------------------------------------------------------------------
// Precomputed primitives.

struct PlaneData {
  Eigen::Vector3d origin, normal;  // unit normal
  Eigen::Vector3d dual_u, dual_v;  // a = dual_u . (p - origin), b = dual_v . (p - origin)
  double len_u, len_v;
  bool bounded;
  Texture texture;
  // For the ray origin of the compiled world: with to = origin - ray origin,
  // num = normal . to, a_off = dual_u . to, b_off = dual_v . to.
  double num = 0, a_off = 0, b_off = 0;
};

struct SphereData {
  Eigen::Vector3d center;
  double radius2;
  double radius;
  Texture texture;
  // For the ray origin o of the compiled world: oc = o - center, c = |oc|^2 - r^2.
  Eigen::Vector3d oc = Eigen::Vector3d::Zero();
  double c = 0;
};

// The world prepared for rays from one origin.
struct CompiledWorld {
  Eigen::Vector3d origin;
  std::vector<PlaneData> planes;
  std::vector<SphereData> spheres;
};

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

CompiledWorld compile(const SyntheticWorld& world, const Eigen::Vector3d& ray_origin) {
  if (!ray_origin.allFinite()) throw InputError("synthetic scene: ray origin is not finite");
  CompiledWorld out;
  out.origin = ray_origin;
  out.planes.reserve(world.planes.size());
  for (size_t i = 0; i < world.planes.size(); ++i) {
    const SyntheticPlane& pl = world.planes[i];
    const Eigen::Vector3d cross = pl.axis_u.cross(pl.axis_v);
    const double lu = pl.axis_u.norm(), lv = pl.axis_v.norm();
    if (!finite(pl.origin) || !finite(pl.axis_u) || !finite(pl.axis_v) ||
        !(cross.norm() > 1e-9 * lu * lv) || !(lu > 0) || !(lv > 0)) {
      std::ostringstream msg;
      msg << "synthetic plane " << i << ": axes must be finite and not parallel";
      throw InputError(msg.str());
    }
    if (!(pl.texture_scale > 0) || !std::isfinite(pl.texture_scale) ||
        !std::isfinite(pl.texture_contrast)) {
      std::ostringstream msg;
      msg << "synthetic plane " << i << ": texture_scale must be positive and finite";
      throw InputError(msg.str());
    }
    PlaneData d{{}, {}, {}, {}, 0, 0, true,
                Texture(pl.texture_seed, pl.texture_scale, pl.texture_contrast)};
    d.origin = pl.origin;
    d.normal = cross.normalized();
    const double uu = pl.axis_u.dot(pl.axis_u), uv = pl.axis_u.dot(pl.axis_v),
                 vv = pl.axis_v.dot(pl.axis_v);
    const double det = uu * vv - uv * uv;
    d.dual_u = (vv * pl.axis_u - uv * pl.axis_v) / det;
    d.dual_v = (uu * pl.axis_v - uv * pl.axis_u) / det;
    d.len_u = lu;
    d.len_v = lv;
    d.bounded = pl.bounded;
    const Eigen::Vector3d to = pl.origin - ray_origin;
    d.num = d.normal.dot(to);
    d.a_off = d.dual_u.dot(to);
    d.b_off = d.dual_v.dot(to);
    out.planes.push_back(d);
  }
  out.spheres.reserve(world.spheres.size());
  for (size_t i = 0; i < world.spheres.size(); ++i) {
    const SyntheticSphere& sp = world.spheres[i];
    if (!finite(sp.center) || !(sp.radius > 0) || !std::isfinite(sp.radius) ||
        !(sp.texture_scale > 0) || !std::isfinite(sp.texture_scale) ||
        !std::isfinite(sp.texture_contrast)) {
      std::ostringstream msg;
      msg << "synthetic sphere " << i
          << ": centre must be finite, radius and texture_scale positive";
      throw InputError(msg.str());
    }
    SphereData d{{}, 0, 0, Texture(sp.texture_seed, sp.texture_scale, sp.texture_contrast)};
    d.center = sp.center;
    d.radius = sp.radius;
    d.radius2 = sp.radius * sp.radius;
    d.oc = ray_origin - sp.center;
    d.c = d.oc.squaredNorm() - d.radius2;
    out.spheres.push_back(d);
  }
  return out;
}

// Nearest intersection. kind: 0 none, 1 plane, 2 sphere; index and, for
// planes, the surface coordinates (a, b) of the hit.
struct Intersection {
  int kind = 0;
  int index = -1;
  double s = std::numeric_limits<double>::infinity();
  double a = 0, b = 0;
};

// Nearest hit along w.origin + s*d.
Intersection intersect(const CompiledWorld& w, const Eigen::Vector3d& d) {
  Intersection best;
  for (size_t i = 0; i < w.planes.size(); ++i) {
    const PlaneData& pl = w.planes[i];
    const double denom = pl.normal.dot(d);
    if (denom == 0.0) continue;
    const double s = pl.num / denom;
    if (!(s > kMinRayParameter) || !(s < best.s)) continue;
    const double a = s * pl.dual_u.dot(d) - pl.a_off;
    const double b = s * pl.dual_v.dot(d) - pl.b_off;
    if (pl.bounded && !(a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0)) continue;
    best.kind = 1;
    best.index = static_cast<int>(i);
    best.s = s;
    best.a = a;
    best.b = b;
  }
  const double dd = d.squaredNorm();
  for (size_t i = 0; i < w.spheres.size(); ++i) {
    const SphereData& sp = w.spheres[i];
    const double half_b = sp.oc.dot(d);
    const double disc = half_b * half_b - dd * sp.c;
    if (disc < 0) continue;
    const double root = std::sqrt(disc);
    double s = (-half_b - root) / dd;
    if (!(s > kMinRayParameter)) s = (-half_b + root) / dd;
    if (!(s > kMinRayParameter) || !(s < best.s)) continue;
    best.kind = 2;
    best.index = static_cast<int>(i);
    best.s = s;
  }
  return best;
}

// Unit world normal facing the ray at the intersection.
Eigen::Vector3d hitNormal(const CompiledWorld& w, const Intersection& hit,
                          const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Eigen::Vector3d n;
  if (hit.kind == 1) {
    n = w.planes[hit.index].normal;
  } else {
    const SphereData& sp = w.spheres[hit.index];
    n = (o + hit.s * d - sp.center).normalized();
  }
  if (n.dot(d) > 0) n = -n;
  return n;
}

Eigen::Vector3d hitColor(const CompiledWorld& w, const Intersection& hit,
                         const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  if (hit.kind == 1) {
    const PlaneData& pl = w.planes[hit.index];
    const double p[3] = {hit.a * pl.len_u, hit.b * pl.len_v, 0.0};
    return pl.texture.color(p, 2);
  }
  const SphereData& sp = w.spheres[hit.index];
  const Eigen::Vector3d rel = o + hit.s * d - sp.center;
  const double p[3] = {rel.x(), rel.y(), rel.z()};
  return sp.texture.color(p, 3);
}

void checkCamera(const PinholeCamera& camera) {
  const std::string why = camera.validate();
  if (!why.empty()) throw InputError("synthetic scene camera: " + why);
}

// World direction of the camera ray through (u, v), with camera-z component 1.
inline Eigen::Vector3d rayDirection(const Eigen::Matrix3d& Rt, const PinholeCamera& cam,
                                    double u, double v) {
  return Rt * Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
}

inline uint8_t toByte(double value) {
  const double r = std::floor(value + 0.5);
  return static_cast<uint8_t>(std::min(255.0, std::max(0.0, r)));
}

}  // namespace

void addBox(SyntheticWorld& world, const Eigen::Vector3d& center, const Eigen::Vector3d& size,
            double yaw, uint32_t texture_seed, double texture_scale, const Eigen::Vector3d& up) {
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(yaw, up.normalized()).toRotationMatrix();
  const Eigen::Vector3d ex = rot * Eigen::Vector3d(size.x(), 0, 0);
  const Eigen::Vector3d ey = rot * Eigen::Vector3d(0, size.y(), 0);
  const Eigen::Vector3d ez = rot * Eigen::Vector3d(0, 0, size.z());
  const Eigen::Vector3d corner = center - 0.5 * (ex + ey + ez);
  struct Face {
    Eigen::Vector3d origin, u, v;
  };
  const Face faces[6] = {
      {corner, ex, ey},      {corner + ez, ex, ey},  // bottom, top
      {corner, ex, ez},      {corner + ey, ex, ez},  // front, back
      {corner, ey, ez},      {corner + ex, ey, ez},  // left, right
  };
  for (int f = 0; f < 6; ++f) {
    SyntheticPlane pl;
    pl.origin = faces[f].origin;
    pl.axis_u = faces[f].u;
    pl.axis_v = faces[f].v;
    pl.texture_seed = deriveSeed(texture_seed, 100 + f);
    pl.texture_scale = texture_scale;
    world.planes.push_back(pl);
  }
}

RayHit castRay(const SyntheticWorld& world, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction) {
  const CompiledWorld w = compile(world, origin);
  RayHit out;
  const Intersection hit = intersect(w, direction);
  if (hit.kind == 0) return out;
  out.hit = true;
  out.s = hit.s;
  out.point = origin + hit.s * direction;
  out.normal = hitNormal(w, hit, origin, direction);
  out.color = hitColor(w, hit, origin, direction);
  return out;
}

double depthAt(const SyntheticWorld& world, const PinholeCamera& camera, double u, double v) {
  checkCamera(camera);
  const CompiledWorld w = compile(world, camera.center());
  const Eigen::Matrix3d Rt = camera.R.transpose();
  const Intersection hit = intersect(w, rayDirection(Rt, camera, u, v));
  return hit.kind == 0 ? std::numeric_limits<double>::quiet_NaN() : hit.s;
}

uint8_t radianceToByte(double radiance) { return toByte(radiance); }

RenderedView renderView(const SyntheticWorld& world, const PinholeCamera& camera,
                        int supersampling) {
  return renderViewByRows(
      world, camera, [&camera](int) { return RowExposure{camera, {}}; }, supersampling,
      [](double radiance, int, int, int) { return toByte(radiance); });
}

RenderedView renderViewByRows(const SyntheticWorld& world, const PinholeCamera& camera,
                              const std::function<RowExposure(int row)>& row_exposure, int supersampling,
                              const RadianceToLevel& to_level) {
  checkCamera(camera);
  if (supersampling < 1 || supersampling > 16) {
    throw InputError("renderView: supersampling must be in [1, 16], got " +
                     std::to_string(supersampling));
  }
  compile(world, camera.center());  // refuses an invalid world here, not inside the parallel loop
  const int width = camera.width, height = camera.height, n = supersampling;
  // Every row's poses first (checked, in order), so that nothing throws
  // inside the parallel loop.
  std::vector<RowExposure> rows(height);
  for (int y = 0; y < height; ++y) {
    rows[y] = row_exposure(y);
    checkCamera(rows[y].mid);
    for (const PinholeCamera& sample : rows[y].samples) checkCamera(sample);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();

  RenderedView out;
  out.camera = camera;
  out.image = ImageU8(width, height, 3, 0);
  out.depth = ImageF(width, height, 1, nan);
  out.normal = ImageF(width, height, 3, nan);

  std::vector<double> offsets(n);
  for (int i = 0; i < n; ++i) offsets[i] = (i + 0.5) / n - 0.5;

#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 2)
#endif
  for (int y = 0; y < height; ++y) {
    const PinholeCamera& mid = rows[y].mid;
    const std::vector<PinholeCamera> colour_poses =
        rows[y].samples.empty() ? std::vector<PinholeCamera>{mid} : rows[y].samples;
    // A compiled world per pose: rays are cast from that pose's centre.
    std::vector<CompiledWorld> compiled;
    std::vector<Eigen::Matrix3d> rotations;
    for (const PinholeCamera& pose : colour_poses) {
      compiled.push_back(compile(world, pose.center()));
      rotations.push_back(pose.R.transpose());
    }
    const CompiledWorld mid_world = compile(world, mid.center());
    const Eigen::Matrix3d mid_Rt = mid.R.transpose();
    const double inv_samples = 1.0 / (n * n * static_cast<double>(colour_poses.size()));
    for (int x = 0; x < width; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < colour_poses.size(); ++k) {
        const Eigen::Vector3d origin = colour_poses[k].center();
        for (int j = 0; j < n; ++j) {
          for (int i = 0; i < n; ++i) {
            const Eigen::Vector3d d = rayDirection(rotations[k], colour_poses[k], x + offsets[i], y + offsets[j]);
            const Intersection hit = intersect(compiled[k], d);
            if (hit.kind != 0) sum += hitColor(compiled[k], hit, origin, d);
          }
        }
      }
      for (int c = 0; c < 3; ++c) out.image.at(x, y, c) = to_level(sum[c] * inv_samples, x, y, c);

      const Eigen::Vector3d d = rayDirection(mid_Rt, mid, x, y);
      const Intersection hit = intersect(mid_world, d);
      if (hit.kind != 0) {
        out.depth.at(x, y) = static_cast<float>(hit.s);
        const Eigen::Vector3d nc = mid.R * hitNormal(mid_world, hit, mid.center(), d);
        for (int c = 0; c < 3; ++c) out.normal.at(x, y, c) = static_cast<float>(nc[c]);
      }
    }
  }
  return out;
}

PinholeCamera makeLookAtCamera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                               const Eigen::Vector3d& up, int width, int height,
                               double focal_ratio) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x_raw = z.cross(up);
  if (!z.allFinite() || !(x_raw.norm() > 1e-9 * up.norm())) {
    throw InputError("makeLookAtCamera: viewing direction is zero or parallel to up");
  }
  const Eigen::Vector3d x = x_raw.normalized();
  const Eigen::Vector3d y = z.cross(x);
  PinholeCamera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = focal_ratio * width;
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  cam.R.row(0) = x.transpose();
  cam.R.row(1) = y.transpose();
  cam.R.row(2) = z.transpose();
  cam.t = -cam.R * eye;
  checkCamera(cam);
  return cam;
}

SyntheticPlane makeTexturedQuad(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis_u,
                                const Eigen::Vector3d& axis_v, uint32_t texture_seed,
                                double texture_scale, double texture_contrast) {
  SyntheticPlane plane;
  plane.origin = origin;
  plane.axis_u = axis_u;
  plane.axis_v = axis_v;
  plane.texture_seed = texture_seed;
  plane.texture_scale = texture_scale;
  plane.texture_contrast = texture_contrast;
  return plane;
}

SyntheticWorld makeSlantedPlanesWorld(uint32_t seed) {
  SplitMix rng(seed);
  SyntheticWorld world;
  auto quad = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
                  double scale) { world.planes.push_back(makeTexturedQuad(o, u, v, rng.next32(), scale)); };
  auto jitter = [&](double amount) {
    return Eigen::Vector3d(rng.uniform(-amount, amount), rng.uniform(-amount, amount),
                           rng.uniform(-amount, amount));
  };
  // Back wall at z = 6, wide enough for sideways cameras of any sensible FOV.
  quad({-14.0, -12.0, 6.0}, {28.0, 0, 0}, {0, 24.0, 0}, 0.13);
  // Left: turned about the vertical axis, receding from z ~2.6 (outer edge)
  // to ~4.2 (inner edge).
  quad(Eigen::Vector3d(-2.7, -1.7, 2.6) + jitter(0.15), Eigen::Vector3d(2.3, 0, 1.6),
       Eigen::Vector3d(0, 3.0, 0) + jitter(0.1), 0.07);
  // Right: a ramp tilted about the horizontal axis, from (y 1.7, z 3.0) at the
  // bottom to (y -1.0, z 5.0) at the top.
  quad(Eigen::Vector3d(0.5, 1.7, 3.0) + jitter(0.15), Eigen::Vector3d(2.4, 0, 0) + jitter(0.1),
       Eigen::Vector3d(0, -2.7, 2.0), 0.08);
  // Upper middle: tilted about both axes, nearest (~2.1 m).
  quad(Eigen::Vector3d(-0.9, -1.7, 2.1) + jitter(0.1), Eigen::Vector3d(1.4, 0.2, 0.5),
       Eigen::Vector3d(0.1, 0.9, 0.3) + jitter(0.05), 0.05);
  return world;
}

std::vector<PinholeCamera> makeSidewaysCameras(int count, int width, int height,
                                               double baseline, double convergence_distance,
                                               double focal_ratio) {
  if (count < 1 || width < 1 || height < 1 || !(focal_ratio > 0)) {
    throw InputError("makeSidewaysCameras: count, image size and focal ratio must be positive");
  }
  std::vector<PinholeCamera> cams;
  for (int i = 0; i < count; ++i) {
    const int step = (i + 1) / 2;
    const double x = (i % 2 == 1 ? 1.0 : -1.0) * step * baseline;
    const Eigen::Vector3d eye(x, 0, 0);
    const Eigen::Vector3d target =
        convergence_distance > 0 ? Eigen::Vector3d(0, 0, convergence_distance)
                                 : Eigen::Vector3d(x, 0, 1.0);
    // World up is -y (y points down in this frame).
    cams.push_back(makeLookAtCamera(eye, target, -Eigen::Vector3d::UnitY(), width, height,
                                    focal_ratio));
  }
  return cams;
}

SyntheticWorld makeIndoorRoomWorld(uint32_t seed) {
  SplitMix rng(seed);
  SyntheticWorld world;
  const double lx = 6.0, ly = 5.0, lz = 2.6;
  auto quad = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
                  double scale, double contrast = 1.0) {
    world.planes.push_back(makeTexturedQuad(o, u, v, rng.next32(), scale, contrast));
  };
  // Floor and ceiling.
  quad({0, 0, 0}, {lx, 0, 0}, {0, ly, 0}, 0.08);
  quad({0, 0, lz}, {lx, 0, 0}, {0, ly, 0}, 0.12);
  // Walls x = 0, y = 0, y = 5.
  quad({0, 0, 0}, {0, ly, 0}, {0, 0, lz}, 0.12);
  quad({0, 0, 0}, {lx, 0, 0}, {0, 0, lz}, 0.10);
  quad({0, ly, 0}, {lx, 0, 0}, {0, 0, lz}, 0.10);
  // Wall x = 6: textured for y in [0, 3.2], weakly textured beyond.
  const double split = 3.2;
  quad({lx, 0, 0}, {0, split, 0}, {0, 0, lz}, 0.10);
  quad({lx, split, 0}, {0, ly - split, 0}, {0, 0, lz}, 0.15, 0.1);

  // Boxes on the floor, one stacked on another.
  const double yaw1 = rng.uniform(0.2, 0.5), yaw2 = rng.uniform(-0.35, -0.1);
  const Eigen::Vector3d b1(3.8 + rng.uniform(-0.15, 0.15), 2.0 + rng.uniform(-0.15, 0.15), 0.4);
  addBox(world, b1, {0.8, 0.8, 0.8}, yaw1, rng.next32(), 0.05);
  const Eigen::Vector3d b2(4.4 + rng.uniform(-0.1, 0.1), 3.15 + rng.uniform(-0.1, 0.1), 0.3);
  addBox(world, b2, {1.0, 0.6, 0.6}, yaw2, rng.next32(), 0.05);
  addBox(world, b1 + Eigen::Vector3d(0.05, -0.05, 0.6), {0.4, 0.4, 0.4},
         yaw1 + rng.uniform(0.3, 0.6), rng.next32(), 0.04);

  // Ramp rising along +x toward the second box, ending 0.45 m high.
  const double ramp_y = 2.95 + rng.uniform(-0.05, 0.05);
  quad({2.65, ramp_y, 0.0}, {1.15, 0, 0.45}, {0, 0.6, 0}, 0.05);

  // Sphere resting on the floor.
  SyntheticSphere ball;
  ball.radius = 0.35 + rng.uniform(-0.05, 0.05);
  ball.center = {2.9 + rng.uniform(-0.1, 0.1), 1.2 + rng.uniform(-0.1, 0.1), ball.radius};
  ball.texture_seed = rng.next32();
  ball.texture_scale = 0.04;
  world.spheres.push_back(ball);
  return world;
}

PinholeCamera smoothTrajectoryCamera(double s, int width, int height, uint32_t seed) {
  SplitMix rng(seed);
  const double phase1 = rng.uniform(0, 2 * kPi), phase2 = rng.uniform(0, 2 * kPi),
               phase3 = rng.uniform(0, 2 * kPi), phase4 = rng.uniform(0, 2 * kPi);
  const Eigen::Vector3d eye(1.0 + 0.35 * std::sin(kPi * s + phase1), 1.1 + 2.6 * s,
                            1.45 + 0.1 * std::sin(2 * kPi * s + phase2));
  const Eigen::Vector3d target(4.0 + 0.2 * std::sin(2 * kPi * s + phase3),
                               2.5 + 0.25 * std::cos(kPi * s + phase4), 0.5);
  return makeLookAtCamera(eye, target, Eigen::Vector3d::UnitZ(), width, height, 0.8);
}

std::vector<PinholeCamera> makeSmoothTrajectory(int count, int width, int height,
                                                uint32_t seed) {
  if (count < 1 || width < 1 || height < 1) {
    throw InputError("makeSmoothTrajectory: count and image size must be positive");
  }
  std::vector<PinholeCamera> cams;
  for (int i = 0; i < count; ++i) {
    const double s = count > 1 ? static_cast<double>(i) / (count - 1) : 0.0;
    cams.push_back(smoothTrajectoryCamera(s, width, height, seed));
  }
  return cams;
}

}  // namespace amhmvs
