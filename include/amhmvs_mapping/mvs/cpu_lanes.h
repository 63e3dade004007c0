// SIMD lanes for the CPU backend (GCC/Clang vector extensions: SSE2 on any
// x86-64, NEON on arm64; no intrinsics, no -march needed).
//
// The matching cost (matching_cost.h) is written over a per-lane float type F.
// The GPU and the scalar CPU use F = float; the CPU backend uses FloatLanes,
// whose lanes each score their own (hypothesis, source view) pair. Every lane
// runs the same IEEE operations in the same order as the scalar code (no
// contraction into FMA, no reassociation), so the costs are bit-identical.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace amhmvs {
namespace mvs {

constexpr int kCpuLanes = 4;

typedef float FloatLanes __attribute__((vector_size(4 * kCpuLanes)));
typedef int IntLanes __attribute__((vector_size(4 * kCpuLanes)));  // also the masks: -1 or 0

inline FloatLanes splat(float v) { return FloatLanes{} + v; }

template <class F>
struct LaneMath;

template <>
struct LaneMath<FloatLanes> {
  static FloatLanes splat(float v) { return mvs::splat(v); }
  static bool any(IntLanes mask) {
    int any = 0;
    for (int l = 0; l < kCpuLanes; ++l) any |= mask[l];
    return any != 0;
  }
  static FloatLanes select(IntLanes mask, FloatLanes a, FloatLanes b) { return mask ? a : b; }
  static FloatLanes reciprocal(FloatLanes x) { return 1.0f / x; }
  static FloatLanes sqrt(FloatLanes x) {
    FloatLanes r{};
    for (int l = 0; l < kCpuLanes; ++l) r[l] = std::sqrt(x[l]);
    return r;
  }
};

inline IntLanes truncateToInt(FloatLanes x) { return __builtin_convertvector(x, IntLanes); }
inline FloatLanes toFloat(IntLanes x) { return __builtin_convertvector(x, FloatLanes); }

// x > lo ? (x < hi ? x : hi) : lo, lane by lane (NaN gives lo); hi > lo.
inline FloatLanes clampLanes(FloatLanes x, float lo, FloatLanes hi) {
#if defined(__SSE2__)
  // maxps(a, b) is a > b ? a : b and minps(a, b) is a < b ? a : b, exactly.
  return (FloatLanes)_mm_min_ps(_mm_max_ps((__m128)x, _mm_set1_ps(lo)), (__m128)hi);
#else
  x = x > lo ? x : FloatLanes{} + lo;
  return x < hi ? x : hi;
#endif
}

// Two horizontally adjacent bytes per lane, at origin[l] + row[l] * stride[l]
// + column[l] and one row below, each pair as p[0] | p[1] << 8.
struct BytePairGather {
  const uint8_t* origin[kCpuLanes];
  int stride[kCpuLanes];
  int max_row[kCpuLanes];
#if defined(__SSE2__)
  bool short_offsets = false;  // rows, columns and strides fit in 16 bits
  __m128i stride_and_one;      // per lane the 16-bit pair (1, stride), for pmaddwd
#endif

  // Rows in -max_row .. max_row, columns in -stride .. stride.
  void setLane(int l, const uint8_t* lane_origin, int lane_stride, int lane_max_row) {
    origin[l] = lane_origin;
    stride[l] = lane_stride;
    max_row[l] = lane_max_row;
  }
  void finish() {
#if defined(__SSE2__)
    static_assert(kCpuLanes == 4, "one lane per 32-bit slot of an SSE register");
    short_offsets = true;
    for (int l = 0; l < kCpuLanes; ++l) {
      short_offsets = short_offsets && stride[l] <= INT16_MAX && max_row[l] <= INT16_MAX;
    }
    stride_and_one = _mm_setr_epi32(1 | stride[0] << 16, 1 | stride[1] << 16,
                                    1 | stride[2] << 16, 1 | stride[3] << 16);
#endif
  }

  void gather(IntLanes column, IntLanes row, IntLanes* top, IntLanes* bottom) const {
#if defined(__SSE2__)
    if (short_offsets) {
      // row * stride + column for all lanes in one pmaddwd of 16-bit halves.
      const __m128i packed =
          _mm_or_si128(_mm_and_si128((__m128i)column, _mm_set1_epi32(0xffff)),
                       _mm_slli_epi32((__m128i)row, 16));
      alignas(16) int32_t offset[kCpuLanes];
      _mm_store_si128(reinterpret_cast<__m128i*>(offset), _mm_madd_epi16(packed, stride_and_one));
      auto pair = [](const uint8_t* p) {
        uint16_t v;
        std::memcpy(&v, p, 2);  // little-endian: p[0] | p[1] << 8
        return static_cast<int>(v);
      };
      __m128i t = _mm_setzero_si128(), b = _mm_setzero_si128();
      const uint8_t* p0 = origin[0] + offset[0];
      const uint8_t* p1 = origin[1] + offset[1];
      const uint8_t* p2 = origin[2] + offset[2];
      const uint8_t* p3 = origin[3] + offset[3];
      t = _mm_insert_epi16(t, pair(p0), 0);
      b = _mm_insert_epi16(b, pair(p0 + stride[0]), 0);
      t = _mm_insert_epi16(t, pair(p1), 2);
      b = _mm_insert_epi16(b, pair(p1 + stride[1]), 2);
      t = _mm_insert_epi16(t, pair(p2), 4);
      b = _mm_insert_epi16(b, pair(p2 + stride[2]), 4);
      t = _mm_insert_epi16(t, pair(p3), 6);
      b = _mm_insert_epi16(b, pair(p3 + stride[3]), 6);
      *top = (IntLanes)t;
      *bottom = (IntLanes)b;
      return;
    }
#endif
    for (int l = 0; l < kCpuLanes; ++l) {
      const uint8_t* p = origin[l] + static_cast<ptrdiff_t>(row[l]) * stride[l] + column[l];
      (*top)[l] = p[0] | (p[1] << 8);
      (*bottom)[l] = p[stride[l]] | (p[stride[l] + 1] << 8);
    }
  }
};

}  // namespace mvs
}  // namespace amhmvs
