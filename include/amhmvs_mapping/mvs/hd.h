// Small host/device vector math shared by the CPU and CUDA backends.
//
// The per-pixel algorithm is written once against these types and compiled
// by g++ (CPU backend) and nvcc (CUDA backend), so both run the same code.
#pragma once

#include <cmath>
#include <cstdint>

#if defined(__CUDACC__)
#define AMHMVS_HD __host__ __device__ __forceinline__
#define AMHMVS_UNROLL _Pragma("unroll")
#else
#define AMHMVS_HD inline
#define AMHMVS_UNROLL  // g++ -O3 unrolls the constant-count loops itself
#endif

namespace amhmvs {
namespace mvs {

struct Vec3 {
  float x, y, z;
};

AMHMVS_HD Vec3 make_vec3(float x, float y, float z) { return Vec3{x, y, z}; }
AMHMVS_HD Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
AMHMVS_HD Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
AMHMVS_HD Vec3 operator*(float s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
AMHMVS_HD float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
AMHMVS_HD Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
AMHMVS_HD float rsqrtf_hd(float x) { return 1.0f / sqrtf(x); }

// 1 / x, correctly rounded for normal x (as the CPU's division). On the GPU,
// nvcc's IEEE division carries a branch to a slow path for extreme exponents;
// in the window loop that branch keeps texture fetches from being issued
// ahead of their use. This is the same hardware estimate and Newton step
// without the branch (exact away from denormals and overflow).
AMHMVS_HD float reciprocal(float x) {
#if defined(__CUDA_ARCH__)
  float r;
  asm("rcp.approx.ftz.f32 %0, %1;" : "=f"(r) : "f"(x));
  const float e = fmaf(-x, r, 1.0f);
  return fmaf(r, e, r);
#else
  return 1.0f / x;
#endif
}
AMHMVS_HD float nanf_hd() { return nanf(""); }
AMHMVS_HD bool isfinite_hd(double v) {
#if defined(__CUDA_ARCH__)
  return isfinite(v);
#else
  return std::isfinite(v);
#endif
}

AMHMVS_HD Vec3 normalized(Vec3 a) {
  const float inv = 1.0f / sqrtf(dot(a, a));
  return inv * a;
}

// Row-major 3x3 matrix.
struct Mat3 {
  float m[9];
};

AMHMVS_HD Vec3 mul(const Mat3& a, Vec3 v) {
  return {a.m[0] * v.x + a.m[1] * v.y + a.m[2] * v.z, a.m[3] * v.x + a.m[4] * v.y + a.m[5] * v.z,
          a.m[6] * v.x + a.m[7] * v.y + a.m[8] * v.z};
}

// Slanted plane hypothesis of one pixel, in the reference camera frame:
// points X on the plane satisfy n . X + d = 0, with unit normal n facing the
// camera (n . X < 0 for visible points), so d > 0.
struct Plane {
  Vec3 n;
  float d;
};

// Pinhole intrinsics of the reference camera.
struct Intrinsics {
  float fx, fy, cx, cy;
};

AMHMVS_HD Vec3 pixelRay(const Intrinsics& k, float u, float v) {
  return {(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0f};
}

// z-depth at which the ray through (u, v) meets the plane; <= 0 or non-finite
// when the plane is seen edge-on or from behind.
AMHMVS_HD float planeDepth(const Plane& p, Vec3 ray) {
  const float denom = dot(p.n, ray);
  return -p.d / denom;
}

AMHMVS_HD Plane planeFromDepthNormal(Vec3 n, float depth, Vec3 ray) {
  return {n, -dot(n, depth * ray)};
}

}  // namespace mvs
}  // namespace amhmvs
