// Two doubles (or four floats) per register: the renderer traces and shades two samples at a
// time where their work is independent (camera rays, the earth's texture, sun rays). With SSE2
// (every x86-64) these are its intrinsics; without it (or with SVMS_RENDER_NO_SSE2) the same
// names do the same operations lane by lane. IEEE arithmetic either way, so both give the same
// bits, and every two-lane helper does what its scalar twin in render_math.h does, operation
// for operation. Internal to sim (not installed).
#pragma once

#if defined(__SSE2__) && !defined(SVMS_RENDER_NO_SSE2)
#define SVMS_RENDER_SSE2 1
#include <emmintrin.h>
#endif

#include <cmath>
#include <cstdint>
#include <cstring>

#include "svms/sim/render_math.h"

namespace svms::render {

#if SVMS_RENDER_SSE2
using F64x2 = __m128d;
using F32x4 = __m128;
// All ones in the lanes whose sign bit is set.
inline F64x2 SignMask(F64x2 x) {
  return _mm_castsi128_pd(
      _mm_srai_epi32(_mm_shuffle_epi32(_mm_castpd_si128(x), _MM_SHUFFLE(3, 3, 1, 1)), 31));
}
// Truncated toward zero (|x| < 2^31), and as ints.
inline F64x2 TruncPd(F64x2 x) { return _mm_cvtepi32_pd(_mm_cvttpd_epi32(x)); }
inline void StoreInt2(F64x2 x, int* out) {
  alignas(16) int t[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(t), _mm_cvttpd_epi32(x));
  out[0] = t[0];
  out[1] = t[1];
}
#else
struct F64x2 {
  double v[2];
};
struct F32x4 {
  float v[4];
};
inline F64x2 Lanes(double a, double b) { return F64x2{{a, b}}; }
inline double Bits(uint64_t u) {
  double d;
  std::memcpy(&d, &u, 8);
  return d;
}
inline uint64_t Bits(double d) {
  uint64_t u;
  std::memcpy(&u, &d, 8);
  return u;
}
inline double Mask(bool b) { return Bits(b ? ~uint64_t{0} : uint64_t{0}); }
inline F64x2 _mm_set_pd(double hi, double lo) { return Lanes(lo, hi); }
inline F64x2 _mm_set1_pd(double a) { return Lanes(a, a); }
inline F64x2 _mm_setzero_pd() { return Lanes(0.0, 0.0); }
inline F64x2 _mm_loadu_pd(const double* p) { return Lanes(p[0], p[1]); }
inline void _mm_storeu_pd(double* p, F64x2 a) { p[0] = a.v[0], p[1] = a.v[1]; }
inline void _mm_store_pd(double* p, F64x2 a) { p[0] = a.v[0], p[1] = a.v[1]; }
inline F64x2 _mm_add_pd(F64x2 a, F64x2 b) { return Lanes(a.v[0] + b.v[0], a.v[1] + b.v[1]); }
inline F64x2 _mm_sub_pd(F64x2 a, F64x2 b) { return Lanes(a.v[0] - b.v[0], a.v[1] - b.v[1]); }
inline F64x2 _mm_mul_pd(F64x2 a, F64x2 b) { return Lanes(a.v[0] * b.v[0], a.v[1] * b.v[1]); }
inline F64x2 _mm_div_pd(F64x2 a, F64x2 b) { return Lanes(a.v[0] / b.v[0], a.v[1] / b.v[1]); }
inline F64x2 _mm_sqrt_pd(F64x2 a) { return Lanes(std::sqrt(a.v[0]), std::sqrt(a.v[1])); }
inline F64x2 _mm_min_pd(F64x2 a, F64x2 b) {
  return Lanes(a.v[0] < b.v[0] ? a.v[0] : b.v[0], a.v[1] < b.v[1] ? a.v[1] : b.v[1]);
}
inline F64x2 _mm_max_pd(F64x2 a, F64x2 b) {
  return Lanes(a.v[0] > b.v[0] ? a.v[0] : b.v[0], a.v[1] > b.v[1] ? a.v[1] : b.v[1]);
}
inline F64x2 _mm_and_pd(F64x2 a, F64x2 b) {
  return Lanes(Bits(Bits(a.v[0]) & Bits(b.v[0])), Bits(Bits(a.v[1]) & Bits(b.v[1])));
}
inline F64x2 _mm_or_pd(F64x2 a, F64x2 b) {
  return Lanes(Bits(Bits(a.v[0]) | Bits(b.v[0])), Bits(Bits(a.v[1]) | Bits(b.v[1])));
}
inline F64x2 _mm_andnot_pd(F64x2 a, F64x2 b) {
  return Lanes(Bits(~Bits(a.v[0]) & Bits(b.v[0])), Bits(~Bits(a.v[1]) & Bits(b.v[1])));
}
inline F64x2 _mm_cmpgt_pd(F64x2 a, F64x2 b) {
  return Lanes(Mask(a.v[0] > b.v[0]), Mask(a.v[1] > b.v[1]));
}
inline F64x2 _mm_cmpge_pd(F64x2 a, F64x2 b) {
  return Lanes(Mask(a.v[0] >= b.v[0]), Mask(a.v[1] >= b.v[1]));
}
inline F64x2 _mm_cmplt_pd(F64x2 a, F64x2 b) {
  return Lanes(Mask(a.v[0] < b.v[0]), Mask(a.v[1] < b.v[1]));
}
inline F64x2 _mm_cmple_pd(F64x2 a, F64x2 b) {
  return Lanes(Mask(a.v[0] <= b.v[0]), Mask(a.v[1] <= b.v[1]));
}
inline F64x2 _mm_cmpeq_pd(F64x2 a, F64x2 b) {
  return Lanes(Mask(a.v[0] == b.v[0]), Mask(a.v[1] == b.v[1]));
}
inline int _mm_movemask_pd(F64x2 a) {
  return static_cast<int>(Bits(a.v[0]) >> 63) | static_cast<int>(Bits(a.v[1]) >> 63) << 1;
}
inline F64x2 _mm_unpacklo_pd(F64x2 a, F64x2 b) { return Lanes(a.v[0], b.v[0]); }
inline F64x2 _mm_unpackhi_pd(F64x2 a, F64x2 b) { return Lanes(a.v[1], b.v[1]); }
inline F32x4 _mm_setr_ps(float a, float b, float c, float d) { return F32x4{{a, b, c, d}}; }
inline F32x4 _mm_set1_ps(float a) { return F32x4{{a, a, a, a}}; }
inline F32x4 _mm_add_ps(F32x4 a, F32x4 b) {
  return F32x4{{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2], a.v[3] + b.v[3]}};
}
inline F32x4 _mm_mul_ps(F32x4 a, F32x4 b) {
  return F32x4{{a.v[0] * b.v[0], a.v[1] * b.v[1], a.v[2] * b.v[2], a.v[3] * b.v[3]}};
}
inline F32x4 _mm_movehl_ps(F32x4 a, F32x4 b) { return F32x4{{b.v[2], b.v[3], a.v[2], a.v[3]}}; }
inline F64x2 _mm_cvtps_pd(F32x4 a) { return Lanes(a.v[0], a.v[1]); }
inline F64x2 SignMask(F64x2 x) { return Lanes(Mask(Bits(x.v[0]) >> 63), Mask(Bits(x.v[1]) >> 63)); }
inline F64x2 TruncPd(F64x2 x) {
  return Lanes(static_cast<int32_t>(x.v[0]), static_cast<int32_t>(x.v[1]));
}
inline void StoreInt2(F64x2 x, int* out) {
  out[0] = static_cast<int32_t>(x.v[0]);
  out[1] = static_cast<int32_t>(x.v[1]);
}
#endif

// Both lanes: atan2(y, x), within 2 ulp of glibc's (Cephes atan's rational approximation of
// the ratio of the smaller to the larger magnitude, reduced to [-0.21, 0.66]); the same signed
// zeros and quadrants.
inline F64x2 Atan2Pd(F64x2 y, F64x2 x) {
  const F64x2 sign = _mm_set1_pd(-0.0), zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0);
  const F64x2 ax = _mm_andnot_pd(sign, x), ay = _mm_andnot_pd(sign, y);
  const F64x2 swap = _mm_cmpgt_pd(ay, ax);
  const F64x2 mx = _mm_max_pd(ax, ay), mn = _mm_min_pd(ax, ay);
  const F64x2 big = _mm_cmpgt_pd(mn, _mm_mul_pd(_mm_set1_pd(0.66), mx));
  auto sel = [](F64x2 m, F64x2 a, F64x2 b) {
    return _mm_or_pd(_mm_and_pd(m, a), _mm_andnot_pd(m, b));
  };
  const F64x2 num = sel(big, _mm_sub_pd(mn, mx), mn);
  F64x2 den = sel(big, _mm_add_pd(mn, mx), mx);
  den = sel(_mm_cmpeq_pd(den, zero), one, den);
  const F64x2 z = _mm_div_pd(num, den);
  const F64x2 zz = _mm_mul_pd(z, z);
  F64x2 p = _mm_set1_pd(-8.750608600031904122785E-1);
  p = _mm_add_pd(_mm_mul_pd(p, zz), _mm_set1_pd(-1.615753718733365076637E1));
  p = _mm_add_pd(_mm_mul_pd(p, zz), _mm_set1_pd(-7.500855792314704667340E1));
  p = _mm_add_pd(_mm_mul_pd(p, zz), _mm_set1_pd(-1.228866684490136173410E2));
  p = _mm_add_pd(_mm_mul_pd(p, zz), _mm_set1_pd(-6.485021904942025371773E1));
  F64x2 q = _mm_add_pd(zz, _mm_set1_pd(2.485846490142306297962E1));
  q = _mm_add_pd(_mm_mul_pd(q, zz), _mm_set1_pd(1.650270098316988542046E2));
  q = _mm_add_pd(_mm_mul_pd(q, zz), _mm_set1_pd(4.328810604912902668951E2));
  q = _mm_add_pd(_mm_mul_pd(q, zz), _mm_set1_pd(4.853903996359136964868E2));
  q = _mm_add_pd(_mm_mul_pd(q, zz), _mm_set1_pd(1.945506571482613964425E2));
  // atan(z) = z + z * zz * p / q; the reduction adds pi/4 (in two parts for precision).
  F64x2 r = _mm_add_pd(z, _mm_mul_pd(z, _mm_div_pd(_mm_mul_pd(zz, p), q)));
  const F64x2 pio4_hi = _mm_set1_pd(7.85398163397448278999E-1),
              pio4_lo = _mm_set1_pd(3.061616997868383e-17);
  r = _mm_add_pd(sel(big, pio4_hi, zero), _mm_add_pd(r, sel(big, pio4_lo, zero)));
  const F64x2 pio2_hi = _mm_set1_pd(1.57079632679489655800E0),
              pio2_lo = _mm_set1_pd(6.123233995736766e-17);
  r = sel(swap, _mm_add_pd(_mm_sub_pd(pio2_hi, r), pio2_lo), r);
  const F64x2 pi_hi = _mm_set1_pd(3.14159265358979311600E0),
              pi_lo = _mm_set1_pd(1.2246467991473532e-16);
  const F64x2 xneg = SignMask(x);
  r = sel(xneg, _mm_add_pd(_mm_sub_pd(pi_hi, r), pi_lo), r);
  return _mm_or_pd(r, _mm_and_pd(y, sign));
}

// Two vectors in the two lanes of SSE2 registers, and what the scalar helpers above do, lane
// by lane with the same operations in the same order (so to the bit).
struct V2 {
  F64x2 x, y, z;
};
inline V2 Load2(const Vec3& a, const Vec3& b) {
  return {_mm_set_pd(b[0], a[0]), _mm_set_pd(b[1], a[1]), _mm_set_pd(b[2], a[2])};
}
inline void Store2(const V2& v, Vec3* a, Vec3* b) {
  alignas(16) double t[6];
  _mm_store_pd(t, v.x);
  _mm_store_pd(t + 2, v.y);
  _mm_store_pd(t + 4, v.z);
  *a = Vec3(t[0], t[2], t[4]);
  *b = Vec3(t[1], t[3], t[5]);
}
inline F64x2 Dot2(const V2& a, const V2& b) {
  return _mm_add_pd(_mm_add_pd(_mm_mul_pd(a.x, b.x), _mm_mul_pd(a.y, b.y)), _mm_mul_pd(a.z, b.z));
}
inline V2 Normalized2(const V2& v) {
  const F64x2 n = Dot2(v, v);
  const F64x2 ok = _mm_cmpgt_pd(n, _mm_setzero_pd());
  const F64x2 s = _mm_sqrt_pd(n);
  auto sel = [&](F64x2 a, F64x2 b) { return _mm_or_pd(_mm_and_pd(ok, a), _mm_andnot_pd(ok, b)); };
  return {sel(_mm_div_pd(v.x, s), v.x), sel(_mm_div_pd(v.y, s), v.y), sel(_mm_div_pd(v.z, s), v.z)};
}
inline V2 Mul2(const Mat3& R, const V2& v) {
  auto m = [](double r, F64x2 a) { return _mm_mul_pd(_mm_set1_pd(r), a); };
  return {_mm_add_pd(_mm_add_pd(m(R(0, 0), v.x), m(R(0, 1), v.y)), m(R(0, 2), v.z)),
          _mm_add_pd(_mm_add_pd(m(R(1, 0), v.x), m(R(1, 1), v.y)), m(R(1, 2), v.z)),
          _mm_add_pd(m(R(2, 0), v.x), _mm_add_pd(m(R(2, 1), v.y), m(R(2, 2), v.z)))};
}

}  // namespace svms::render
