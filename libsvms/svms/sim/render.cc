#include "svms/sim/render.h"

#if defined(__SSE2__) && !defined(SVMS_RENDER_NO_SSE2)
#define SVMS_RENDER_SSE2 1
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/camera/photometric.h"
#include "svms/codec/svms44.h"
#include "svms/marker/marker_model.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kEps = 1e-9;           // minimum ray distance, metres
constexpr double kCoplanarWin = 1e-7;   // a marker wins over a coplanar surface by this much
constexpr double kShadowOffset = 1e-6;  // shadow rays start this far off the surface
constexpr int kTile = 16;               // pixels per culling tile side
constexpr int kBlock = 4;               // pixels per classification block side (inside a tile)
constexpr int kGroup = 4;               // pixels whose random numbers are drawn together
constexpr int kMaxFused = 64;           // samples per pixel the fused pixel paths handle

uint64_t Mix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A small deterministic generator for per-pixel jitter: seeded by hashing the pixel, then
// xorshift64* steps (cheap: the sampler draws several numbers per ray).
struct Rng {
  uint64_t s = 1;
  Rng() = default;
  explicit Rng(uint64_t seed) : s(Mix(seed) | 1) {}
  double Uniform() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    // (53 bits: converting them as signed is the same value, without the unsigned fix-up)
    return static_cast<double>(static_cast<int64_t>((s * 0x2545f4914f6cdd1dULL) >> 11)) * 0x1.0p-53;
  }
};

// What a surface point looks like.
struct Surface {
  double reflectance = 0;
  bool retro = false;
  double retro_gain = 0;
  double specular = 0, shininess = 1;
  Vec3 normal = Vec3::Zero();  // world, facing the incoming ray
  int well_prim = -1;          // inside the well of this marker primitive (its walls may shade)
};

struct Prim {
  enum class Kind { kBox, kPlane, kSphere, kMarker };
  Kind kind = Kind::kBox;
  Mat3 R = Mat3::Identity();  // world_from_local rotation
  Vec3 t = Vec3::Zero();      // world_from_local translation
  Vec3 half = Vec3::Ones();   // box / plane half extents; sphere radius in x
  Material material;
  // Markers
  const SceneMarker* marker = nullptr;
  uint64_t word = 0, inner_word = 0;
  double post_h = 0, post_r = 0, tip_r = 0;
  bool has_post = false;
  // Culling
  Vec3 centre;
  double radius = 0;
  bool casts_shadow = true;
  Vec3 post_centre = Vec3::Zero();  // a post marker: sphere around the post alone (world)
  double post_radius = 0;
  double decal_half = 0;  // a marker: half the side of its decal
};

// Local-frame hit.
struct LocalHit {
  double t = 0;     // ray parameter of the hit
  double sort = 0;  // what hits are ordered by (a marker claims coplanar hits)
  Vec3 n_local;     // outward normal, local frame
  Surface surf;
};

// Reflectance of a surface pattern at surface coordinates (u, v), metres.
double PatternAt(const Material& m, double u, double v) {
  const Pattern& p = m.pattern;
  auto cell = [&](double w) { return static_cast<int64_t>(std::floor(w / p.period)); };
  switch (p.kind) {
    case Pattern::Kind::kUniform:
      return m.reflectance;
    case Pattern::Kind::kChecker: {
      if (p.cols > 0) {
        const double hu = 0.5 * p.cols * p.period, hv = 0.5 * p.rows * p.period;
        if (std::abs(u) >= hu || std::abs(v) >= hv) return p.high;
        return ((cell(u + hu) + cell(v + hv)) & 1) ? p.high : p.low;
      }
      return ((cell(u) + cell(v)) & 1) ? p.high : p.low;
    }
    case Pattern::Kind::kStripes:
      return (cell(u) & 1) ? p.high : p.low;
    case Pattern::Kind::kGrid: {
      const double fu = u - p.period * std::floor(u / p.period),
                   fv = v - p.period * std::floor(v / p.period);
      return (fu < p.line || fv < p.line) ? p.low : p.high;
    }
    case Pattern::Kind::kText: {
      // Lines of blocky 5 x 7 glyphs in cells of `period` (wide) x 1.6 period (tall).
      const double gw = p.period, gh = 1.6 * p.period;
      const int64_t gx = static_cast<int64_t>(std::floor(u / gw)),
                    gy = static_cast<int64_t>(std::floor(v / gh));
      const uint64_t g =
          Mix(p.seed ^ Mix(static_cast<uint64_t>(gx) * 0x9e37ULL ^ Mix(static_cast<uint64_t>(gy))));
      if ((g & 7) == 0) return p.high;                                      // a space
      const int px = static_cast<int>(std::floor((u - gx * gw) / gw * 6));  // 5 columns + gap
      const int py = static_cast<int>(std::floor((v - gy * gh) / gh * 9));  // 7 rows + gaps
      if (px >= 5 || py < 1 || py > 7) return p.high;
      return ((Mix(g + py) >> px) & 1) ? p.low : p.high;
    }
    case Pattern::Kind::kNoise: {
      const uint64_t h = Mix(p.seed ^ Mix(static_cast<uint64_t>(cell(u)) * 0x51ULL ^
                                          Mix(static_cast<uint64_t>(cell(v)))));
      return p.low + (p.high - p.low) * ((h >> 11) * 0x1.0p-53);
    }
  }
  return m.reflectance;
}

bool InsideSquare(double x, double y, double half) {
  return std::abs(x) <= half && std::abs(y) <= half;
}

// The bit of each cell of the 12 x 12 grid over the ring ([row][col], row 0 at the top, col 0
// at the left, as printed), inverted once from MarkerModel::BitCellCentre, the one definition of
// the bit layout. A cell inside the ring is reached only by rounding at the ring's inner edge;
// it takes the bit of the ring cell at the left end of its row.
using RingBitTable =
    std::array<std::array<int8_t, MarkerModel::kCellsPerSide>, MarkerModel::kCellsPerSide>;
RingBitTable MakeRingBitTable() {
  constexpr int n = MarkerModel::kCellsPerSide;
  RingBitTable table;
  for (auto& row : table) row.fill(-1);
  MarkerModel unit;  // cell side 1: cell centres at half-integers
  unit.cell_size = 1;
  for (int i = 0; i < Svms44::kBits; ++i) {
    const Eigen::Vector2d c = unit.BitCellCentre(i);
    table[static_cast<int>(std::floor(0.5 * n - c.y()))]
         [static_cast<int>(std::floor(c.x() + 0.5 * n))] = i;
  }
  for (auto& row : table)
    for (int8_t& bit : row)
      if (bit < 0) bit = row[0];
  return table;
}
const RingBitTable kRingBits = MakeRingBitTable();

// Bit index of the ring cell containing (x, y) (inside the ring), for cell size b.
int CellBit(double x, double y, double b) {
  const int col = std::clamp(static_cast<int>(std::floor((x + 6 * b) / b)), 0, 11);
  const int row = std::clamp(static_cast<int>(std::floor((6 * b - y) / b)), 0, 11);
  return kRingBits[row][col];
}

// The printed pattern: true = white, at (x, y) on ring geometry (size s, cell b) with `word`.
// Returns false (and *inside = false) outside the ring.
bool RingWhite(double x, double y, double s, double b, uint64_t word, bool* inside) {
  const double m = std::max(std::abs(x), std::abs(y));
  *inside = m <= 6 * b;
  if (m <= 0.5 * s) return false;
  if (m <= 5 * b) return true;
  return (word >> CellBit(x, y, b)) & 1;
}

// A peer tag (PrintedTag) on a marker of black-square side s and decal half side `half`: its
// n x n grid fills the black square, white around it. Returns false (and *inside = false)
// outside the decal.
bool PeerWhite(double x, double y, double s, double half, const PrintedTag& t, bool* inside) {
  const double m = std::max(std::abs(x), std::abs(y));
  *inside = m <= half;
  if (m > 0.5 * s) return true;
  const int col = std::clamp(static_cast<int>(std::floor((x + 0.5 * s) / s * t.n)), 0, t.n - 1);
  const int row = std::clamp(static_cast<int>(std::floor((0.5 * s - y) / s * t.n)), 0, t.n - 1);
  return t.white[static_cast<size_t>(row) * t.n + col];
}

// Ray-cylinder (axis z through the origin, radius r): roots of |o_xy + t d_xy| = r.
bool CylinderRoots(const Vec3& o, const Vec3& d, double r, double* t0, double* t1) {
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a < 1e-30) return false;
  const double b = o.x() * d.x() + o.y() * d.y();
  const double c = o.x() * o.x() + o.y() * o.y() - r * r;
  const double disc = b * b - a * c;
  if (disc < 0) return false;
  const double q = std::sqrt(disc);
  *t0 = (-b - q) / a;
  *t1 = (-b + q) / a;
  return true;
}

// Small fixed-size products written out: the hot loops call them per ray, and Eigen's generic
// product is not always inlined. Each gives bit for bit what Eigen's expression in the comment
// gives (same operations in the same order), so rendering does not change by a single bit.
inline double Dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}  // a.dot(b)
inline Vec3 Mul(const Mat3& R, const Vec3& v) {  // R * v
  return Vec3(R(0, 0) * v[0] + R(0, 1) * v[1] + R(0, 2) * v[2],
              R(1, 0) * v[0] + R(1, 1) * v[1] + R(1, 2) * v[2],
              R(2, 0) * v[0] + (R(2, 1) * v[1] + R(2, 2) * v[2]));
}
inline Vec3 MulT(const Mat3& R, const Vec3& v) {  // R.transpose() * v
  return Vec3(R(0, 0) * v[0] + R(1, 0) * v[1] + R(2, 0) * v[2],
              R(0, 1) * v[0] + R(1, 1) * v[1] + R(2, 1) * v[2],
              R(0, 2) * v[0] + R(1, 2) * v[1] + R(2, 2) * v[2]);
}
inline Vec3 Normalized(const Vec3& v) {  // v.normalized()
  const double n = Dot(v, v);
  if (!(n > 0)) return v;
  const double s = std::sqrt(n);
  return Vec3(v[0] / s, v[1] / s, v[2] / s);
}
// Squared distance from `oc` (a point relative to the ray origin) to the line along unit `d`:
// (oc - oc.dot(d) * d).squaredNorm(), given along = oc.dot(d).
inline double PerpSquared(const Vec3& oc, double along, const Vec3& d) {
  const Vec3 r(oc[0] - along * d[0], oc[1] - along * d[1], oc[2] - along * d[2]);
  return Dot(r, r);
}
// The bilinear blend of four float corner rays at (fx, fy) in [0, 1]^2, as the Eigen expression
// (1 - fy) * ((1 - fx) * c00 + fx * c10) + fy * ((1 - fx) * c01 + fx * c11) evaluates it.
inline Eigen::Vector3f Blend(const Eigen::Vector3f& c00, const Eigen::Vector3f& c10,
                             const Eigen::Vector3f& c01, const Eigen::Vector3f& c11, double fx,
                             double fy) {
  const float a = static_cast<float>(1 - fy), b = static_cast<float>(1 - fx),
              c = static_cast<float>(fx), e = static_cast<float>(fy);
  Eigen::Vector3f r;
  for (int i = 0; i < 3; ++i) r[i] = a * (b * c00[i] + c * c10[i]) + e * (b * c01[i] + c * c11[i]);
  return r;
}

// Two doubles (four floats) in one register. With SSE2 (every x86-64), its intrinsics; else the
// same operations lane by lane (IEEE arithmetic either way, so the same bits).
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

}  // namespace

// A primitive that a tile's rays may hit, with the ray origin in its local frame.
struct Candidate {
  int prim;
  Vec3 local_origin;
  bool no_post = false;  // its post (if any) cannot be hit by the rays at hand
};

struct Renderer::Impl {
  Scene scene;
  int W = 0, H = 0;
  std::vector<Eigen::Vector3f> corner_dirs;  // (W+1) x (H+1), camera frame, unit; NaN if invalid
  std::vector<Prim> prims;                   // static prims, then occluders
  std::vector<std::vector<int>> view_prims;  // per view: indices into prims
  cv::Mat earth;                             // equirectangular background texture (CV_32F)
  cv::Mat backdrop;                          // background image at the camera's size (CV_32F)

  // A primitive that may block sun rays, with a sphere bounding the part of it that can.
  struct Caster {
    int prim;
    Vec3 centre;
    double radius;
  };

  // What one RenderRadiance call needs to know about its view, computed once.
  struct Frame {
    int view = 0;
    int n = 1;  // samples per pixel side
    const Sun* sun = nullptr;
    Vec3 t1, t2;          // the sun disc's axes
    double sun_r = 0;     // its angular radius
    Vec3 sun_centre_dir;  // the sun direction when the disc has no size
    bool moving = false;  // motion blur
    Vec3 o;               // camera centre (static camera)
    Mat3 Rwc;             // world_from_cam rotation (static camera)
    std::vector<Caster> casters;
    // Sun rays are within angle `sun_spread` of unit `to_sun`; false if that bound is useless.
    bool cull_casters = false;
    Vec3 to_sun;
    double sun_spread = 0;
    // Motion blur: the camera poses WorldFromCam interpolates between.
    Pose cam_a, cam_b;
    Eigen::Quaterniond q_a, q_b;
    bool two_views = false, forward = true;
  };

  // One sample (ray) of a block of pixels, between tracing and shading.
  struct Sample {
    LocalHit hit;           // what it hit (surface normal: world, facing the ray, once shaded)
    int prim = -1;          // -1: the background
    Vec3 d, o;              // the camera ray
    double px = 0, py = 0;  // its image position
    double ux = 0, uy = 0;  // its point of the sun's disc (unit disc)
    Vec3 x;                 // hit point
    Vec3 xs;                // where its sun ray starts (off the surface)
    Vec3 sd;                // the sun direction sampled for it
    double cs = 0;          // cosine of the sun's incidence
    double value = 0;       // radiance of the background, when nothing is hit
  };

  // How a pixel's samples can be traced (see ConeCandidates).
  struct PixelPlan {
    int cover = -1;  // a candidate (index) every ray of the pixel hits: a box, through
    int axis = 0;    // its face `axis` (local), outward normal `sign` along it
    double sign = 0;
    bool face_only = false;  // that box (uniform) is the only candidate
    bool planned = false;    // no candidate, or a covering box: the samples' draws are known
    Vec3 foot_lo = Vec3::Zero(), foot_hi = Vec3::Zero();  // with a covering box: the bounds of
                                                          // where the corner rays meet it
    double foot_t = 0;                                    // and their longest distance
  };

  // One pixel being rendered.
  struct PixelJob {
    int x = 0, y = 0;
    bool valid = false;
    PixelPlan plan;
    std::vector<Candidate>* cands = nullptr;
    Sample* samples = nullptr;
  };

  // Per-call work buffers of RenderRadiance (one per call: renders may run concurrently).
  struct Scratch {
    std::vector<Sample> samples;
    std::vector<Caster> block_casters;
    std::vector<Candidate> moving_candidates;
    std::vector<Candidate> pixel_cands[kGroup];  // of the pixels at hand
    std::vector<int> idx;                        // samples a loop works on
    std::vector<Vec3> grid;                      // the block's corner rays (world, unit)
    std::vector<Candidate> block_cands;
    std::vector<Caster> pixel_casters;
    std::vector<double> ray;  // a pixel's camera rays (see CameraRays)
  };

  const Sun* SunOf(int view) const {
    if (scene.views[view].sun) return &*scene.views[view].sun;
    return scene.light.sun ? &*scene.light.sun : nullptr;
  }

  // Intersects prim `p` with a local-frame ray; false if missed.
  bool Intersect(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
                 bool no_post = false) const {
    switch (p.kind) {
      case Prim::Kind::kBox: {
        // A ray that starts outside a slab and does not head into it misses: what the slab
        // arithmetic below concludes too, without its divisions (most sun rays from a face).
        for (int k = 0; k < 3; ++k) {
          if (o[k] > p.half[k] && d[k] >= 0) return false;
          if (o[k] < -p.half[k] && d[k] <= 0) return false;
        }
        double tn = -1e300, tf = 1e300;
        int axis = 0;
        double sign = 1;
        for (int k = 0; k < 3; ++k) {
          if (std::abs(d[k]) < 1e-300) {
            if (std::abs(o[k]) > p.half[k]) return false;
            continue;
          }
          double a = (-p.half[k] - o[k]) / d[k], b = (p.half[k] - o[k]) / d[k];
          const double s = d[k] > 0 ? -1 : 1;  // face entered
          if (a > b) std::swap(a, b);
          if (a > tn) {
            tn = a;
            axis = k;
            sign = s;
          }
          tf = std::min(tf, b);
        }
        if (tn > tf || tf < kEps) return false;
        if (tn < kEps) return false;  // starts inside: not a visible surface
        h->t = h->sort = tn;
        h->n_local = Vec3::Zero();
        h->n_local[axis] = sign;
        if (p.material.pattern.kind == Pattern::Kind::kUniform) {
          h->surf.reflectance = p.material.reflectance;
        } else {
          const Vec3 q = o + tn * d;
          const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
          h->surf.reflectance = PatternAt(p.material, q[std::min(a1, a2)], q[std::max(a1, a2)]);
        }
        h->surf.specular = p.material.specular;
        h->surf.shininess = p.material.shininess;
        return true;
      }
      case Prim::Kind::kPlane: {
        if (std::abs(d.z()) < 1e-300) return false;
        const double t = -o.z() / d.z();
        if (t < kEps) return false;
        const Vec3 q = o + t * d;
        if (!InsideSquare(q.x() * p.half.y() / p.half.x(), q.y(), p.half.y())) return false;
        h->t = h->sort = t;
        h->n_local = Vec3(0, 0, d.z() < 0 ? 1 : -1);
        h->surf.reflectance = PatternAt(p.material, q.x(), q.y());
        h->surf.specular = p.material.specular;
        h->surf.shininess = p.material.shininess;
        return true;
      }
      case Prim::Kind::kSphere: {
        const double r = p.half.x();
        const double b = o.dot(d), c = o.squaredNorm() - r * r, a = d.squaredNorm();
        const double disc = b * b - a * c;
        if (disc < 0) return false;
        double t = (-b - std::sqrt(disc)) / a;
        if (t < kEps) return false;
        h->t = h->sort = t;
        h->n_local = (o + t * d) / r;
        h->surf.reflectance = p.material.reflectance;
        return true;
      }
      case Prim::Kind::kMarker:
        return IntersectMarker(p, o, d, h, no_post);
    }
    return false;
  }

  bool IntersectMarker(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
                       bool no_post) const {
    const SceneMarker& sm = *p.marker;
    const MarkerModel& m = sm.model;
    bool found = false;
    h->t = h->sort = 1e300;
    auto set = [&](double t, double sort, const Vec3& n, double refl, bool retro, int well) {
      if (sort >= h->sort) return;
      h->t = t;
      h->sort = sort;
      h->n_local = n;
      h->surf = Surface{};
      h->surf.reflectance = refl;
      h->surf.retro = retro && sm.retro;
      h->surf.retro_gain = sm.retro_gain;
      h->surf.well_prim = well;
      found = true;
    };
    // The post: cylinder side and top disc.
    if (p.has_post && p.post_h > 0 && !no_post) {
      double t0, t1;
      if (CylinderRoots(o, d, p.post_r, &t0, &t1)) {
        for (double t : {t0, t1}) {
          if (t < kEps) continue;
          const double z = o.z() + t * d.z();
          if (z >= 0 && z <= p.post_h) {
            const Vec3 q = o + t * d;
            set(t, t, Vec3(q.x(), q.y(), 0) / p.post_r, sm.black, false, -1);
            break;
          }
        }
      }
      if (std::abs(d.z()) > 1e-300) {
        const double t = (p.post_h - o.z()) / d.z();
        if (t > kEps) {
          const Vec3 q = o + t * d;
          const double rho2 = q.x() * q.x() + q.y() * q.y();
          if (rho2 <= p.post_r * p.post_r) {
            const bool white = rho2 <= p.tip_r * p.tip_r;
            set(t, t, Vec3(0, 0, d.z() < 0 ? 1 : -1), white ? sm.white : sm.black, white, -1);
          }
        }
      }
    }
    // The decal (seen from the front only; from behind, the object's body is what is seen).
    if (d.z() < 0) {
      const double t0 = -o.z() / d.z();
      if (t0 > kEps && t0 - kCoplanarWin < h->sort) {
        const Vec3 q = o + t0 * d;
        const double rho2 = q.x() * q.x() + q.y() * q.y();
        if (p.has_post && p.post_h < 0 && rho2 < p.post_r * p.post_r) {
          // Into the well: its white-bottomed floor, or its dark wall.
          const double tb = (p.post_h - o.z()) / d.z();
          const Vec3 qb = o + tb * d;
          const double rb2 = qb.x() * qb.x() + qb.y() * qb.y();
          if (rb2 <= p.post_r * p.post_r) {
            const bool white = rb2 <= p.tip_r * p.tip_r;
            set(tb, t0 - kCoplanarWin, Vec3(0, 0, 1), white ? sm.white : sm.black, white,
                static_cast<int>(&p - prims.data()));
          } else {
            double c0, c1;
            if (CylinderRoots(o, d, p.post_r, &c0, &c1)) {
              const Vec3 qw = o + c1 * d;  // leaving the bore's inside
              set(c1, t0 - kCoplanarWin, -Vec3(qw.x(), qw.y(), 0) / p.post_r, sm.black, false,
                  static_cast<int>(&p - prims.data()));
            }
          }
        } else {
          bool inside = false;
          bool white = false;
          if (sm.print.peer()) {
            white = PeerWhite(q.x(), q.y(), m.size, p.decal_half, sm.print, &inside);
          } else if (m.inner && InsideSquare(q.x(), q.y(), 6 * m.inner->cell_size)) {
            white =
                RingWhite(q.x(), q.y(), m.inner->size, m.inner->cell_size, p.inner_word, &inside);
          } else {
            white = RingWhite(q.x(), q.y(), m.size, m.cell_size, p.word, &inside);
          }
          if (inside)
            set(t0, t0 - kCoplanarWin, Vec3(0, 0, 1), white ? sm.white : sm.black, white, -1);
        }
      }
    }
    return found;
  }

  // Nearest hit over `candidates` for a world ray from `o` (whose local images the candidates
  // carry) along unit `d`.
  bool Nearest(const std::vector<Candidate>& candidates, const Vec3& o, const Vec3& d,
               LocalHit* best, int* best_prim) const {
    best->sort = 1e300;
    *best_prim = -1;
    for (const Candidate& c : candidates) {
      const Prim& p = prims[c.prim];
      // Bounding-sphere rejection.
      const Vec3 oc = p.centre - o;
      const double along = Dot(oc, d);
      if (along < -p.radius) continue;
      if (PerpSquared(oc, along, d) > p.radius * p.radius) continue;
      const Vec3 ld = MulT(p.R, d);
      LocalHit h;
      if (Intersect(p, c.local_origin, ld, &h, c.no_post) && h.sort < best->sort) {
        *best = h;
        *best_prim = c.prim;
      }
    }
    return *best_prim >= 0;
  }

  // Nearest for a pixel whose plan has a covering box: that box's hit is FaceHit's. False if
  // the ray does not hit that box's face after all.
  bool NearestCovered(const std::vector<Candidate>& candidates, const PixelPlan& plan,
                      const Vec3& o, const Vec3& d, LocalHit* best, int* best_prim) const {
    best->sort = 1e300;
    *best_prim = -1;
    for (size_t i = 0; i < candidates.size(); ++i) {
      const Candidate& c = candidates[i];
      const Prim& p = prims[c.prim];
      LocalHit h;
      if (static_cast<int>(i) == plan.cover) {
        if (!FaceHit(c, plan, d, &h)) return false;
      } else {
        const Vec3 oc = p.centre - o;
        const double along = Dot(oc, d);
        if (along < -p.radius) continue;
        if (PerpSquared(oc, along, d) > p.radius * p.radius) continue;
        if (!Intersect(p, c.local_origin, MulT(p.R, d), &h, c.no_post)) continue;
      }
      if (h.sort < best->sort) {
        *best = h;
        *best_prim = c.prim;
      }
    }
    return *best_prim >= 0;
  }

  void AllCandidates(int view, const Vec3& o, std::vector<Candidate>* out) const {
    out->clear();
    for (int i : view_prims[view]) out->push_back({i, MulT(prims[i].R, o - prims[i].t)});
  }
  std::vector<Candidate> AllCandidates(int view, const Vec3& o) const {
    std::vector<Candidate> out;
    AllCandidates(view, o, &out);
    return out;
  }

  // The primitives of view `view` that cast shadows. With `sun` given (rays within its disc
  // only), a post marker whose decal no sun ray can reach from the front is bounded by its
  // post alone; otherwise by its bounding sphere.
  std::vector<Caster> Casters(int view, const Sun* sun) const {
    std::vector<Caster> out;
    double reach = 0, len = 0;
    if (sun) {
      len = sun->to_sun_world.norm();
      // The disc's offsets from to_sun_world are at most this long (t2 is |to_sun| long).
      reach = 0.5 * sun->angular_diameter_deg * M_PI / 180 * std::max(1.0, len);
    }
    for (int i : view_prims[view]) {
      const Prim& p = prims[i];
      if (!p.casts_shadow) continue;
      Caster c{i, p.centre, p.radius};
      // A ray reaches the decal only heading into it (local z < 0).
      if (sun && p.kind == Prim::Kind::kMarker && std::isfinite(len) &&
          Dot(p.R.col(2), sun->to_sun_world) - reach > 1e-9 * len) {
        c.centre = p.post_centre;
        c.radius = p.post_radius;
      }
      out.push_back(c);
    }
    return out;
  }

  // True if `s` (unit, world) from world point `x` is blocked by one of `casters`. `self`: the
  // primitive x is on; a box does not block a sun ray leaving its own lit face (it starts
  // outside, beyond that face, and moves away from its plane: what Intersect finds too).
  bool Shadowed(const Vec3& x, const Vec3& s, int well_prim, const std::vector<Caster>& casters,
                int self = -1) const {
    if (self >= 0 && prims[self].kind != Prim::Kind::kBox) self = -1;
    if (well_prim >= 0) {
      // Leaving the well: through its opening, or blocked by the body around it.
      const Prim& p = prims[well_prim];
      const Vec3 lo = MulT(p.R, x - p.t), ld = MulT(p.R, s);
      if (ld.z() <= 0) return true;
      const Vec3 q = lo + (-lo.z() / ld.z()) * ld;
      if (q.x() * q.x() + q.y() * q.y() > p.post_r * p.post_r) return true;
    }
    for (const Caster& c : casters) {
      if (c.prim == self) continue;
      const Vec3 oc = c.centre - x;
      const double along = Dot(oc, s);
      if (along < -c.radius) continue;
      if (PerpSquared(oc, along, s) > c.radius * c.radius) continue;
      const Prim& p = prims[c.prim];
      const Vec3 lo = MulT(p.R, x - p.t), ld = MulT(p.R, s);
      LocalHit h;
      // Any hit blocks: a post, or a decal (which lies on an opaque surface).
      if (Intersect(p, lo, ld, &h)) return true;
    }
    return false;
  }

  double BackgroundRadiance(const Vec3& d_world, double px, double py) const {
    switch (scene.background.kind) {
      case Background::Kind::kBlack:
        return 0;
      case Background::Kind::kEarth: {
        double value, unused;
        EarthRadiance2(Load2(d_world, d_world), &value, &unused);
        return value;
      }
      case Background::Kind::kImage:
        return scene.background.brightness * Bilinear(backdrop, px, py, false);
    }
    return 0;
  }

  // The earth's radiance in the two (world) directions of `d`: lon = atan2(y, x) and
  // lat = asin(s), s = z / |d| (as atan2(s, sqrt((1 - s) (1 + s)))), within 2 ulp of libm's
  // (the texture lookup is continuous, so the radiance moves by rounding only), for two rays
  // at once.
  void EarthRadiance2(const V2& d, double* a, double* b) const {
    F64x2 lon, lat;
    EarthAngles2(d, &lon, &lat);
    EarthLookup2(lon, lat, a, b);
  }
  static void EarthAngles2(const V2& d, F64x2* lon, F64x2* lat) {
    const F64x2 one = _mm_set1_pd(1.0);
    const F64x2 s =
        _mm_min_pd(_mm_max_pd(_mm_div_pd(d.z, _mm_sqrt_pd(Dot2(d, d))), _mm_set1_pd(-1.0)), one);
    *lon = Atan2Pd(d.y, d.x);
    *lat = Atan2Pd(s, _mm_sqrt_pd(_mm_mul_pd(_mm_sub_pd(one, s), _mm_add_pd(one, s))));
  }

  // Longitude and latitude of a ray d0 by atan2, and of rays near it (a pixel's: 1e-3 rad
  // apart) as those plus their differences: lon - lon0 = atan(t), t = (y x0 - x y0) /
  // (x x0 + y y0), and lat - lat0 = asin(z rho0 - rho z0) (rho the length of the horizontal
  // part; unit rays), by their series up to the fifth power, which for arguments up to 4e-3
  // leaves out less than 1e-17 rad. Rays farther off (or near a pole), by atan2. Measured
  // against libm's atan2 and asin(z / |d|) over random pixels: within 9e-16 rad (lon) and
  // 1.4e-15 rad (lat; nearer the poles than 8 degrees, libm's asin is itself less exact).
  // A radiance image changes by float rounding at most (none of the test scenes by a bit).
  struct EarthRef {
    F64x2 lon0, lat0, x0, y0, z0, r0;
    bool ok;
  };
  static EarthRef MakeEarthRef(const Vec3& d0) {
    EarthRef r;
    EarthAngles2(Load2(d0, d0), &r.lon0, &r.lat0);
    const double rho0 = std::sqrt(d0.x() * d0.x() + d0.y() * d0.y());
    r.ok = rho0 > 0.05;
    r.x0 = _mm_set1_pd(d0.x());
    r.y0 = _mm_set1_pd(d0.y());
    r.z0 = _mm_set1_pd(d0.z());
    r.r0 = _mm_set1_pd(rho0);
    return r;
  }
  void EarthNear2(const EarthRef& r, const V2& d, double* a, double* b) const {
    if (r.ok) {
      const F64x2 lim = _mm_set1_pd(4e-3), sign = _mm_set1_pd(-0.0);
      const F64x2 rho = _mm_sqrt_pd(_mm_add_pd(_mm_mul_pd(d.x, d.x), _mm_mul_pd(d.y, d.y)));
      const F64x2 delta = _mm_sub_pd(_mm_mul_pd(d.z, r.r0), _mm_mul_pd(rho, r.z0));
      const F64x2 c = _mm_add_pd(_mm_mul_pd(d.x, r.x0), _mm_mul_pd(d.y, r.y0));
      const F64x2 s = _mm_sub_pd(_mm_mul_pd(d.y, r.x0), _mm_mul_pd(d.x, r.y0));
      const F64x2 t = _mm_div_pd(s, c);
      const F64x2 ok = _mm_and_pd(_mm_and_pd(_mm_cmple_pd(_mm_andnot_pd(sign, t), lim),
                                             _mm_cmple_pd(_mm_andnot_pd(sign, delta), lim)),
                                  _mm_cmpgt_pd(c, _mm_setzero_pd()));
      if (_mm_movemask_pd(ok) == 3) {
        const F64x2 d2 = _mm_mul_pd(delta, delta), t2 = _mm_mul_pd(t, t);
        const F64x2 dlat = _mm_add_pd(
            delta,
            _mm_mul_pd(_mm_mul_pd(delta, d2),
                       _mm_add_pd(_mm_set1_pd(1.0 / 6), _mm_mul_pd(d2, _mm_set1_pd(3.0 / 40)))));
        const F64x2 dlon = _mm_sub_pd(
            t, _mm_mul_pd(_mm_mul_pd(t, t2),
                          _mm_sub_pd(_mm_set1_pd(1.0 / 3), _mm_mul_pd(t2, _mm_set1_pd(1.0 / 5)))));
        EarthLookup2(_mm_add_pd(r.lon0, dlon), _mm_add_pd(r.lat0, dlat), a, b);
        return;
      }
    }
    EarthRadiance2(d, a, b);
  }

  // The earth's radiance at two (longitude, latitude) pairs.
  void EarthLookup2(F64x2 lon, F64x2 lat, double* a, double* b) const {
    const F64x2 half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0);
    const F64x2 u =
        _mm_sub_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(lon, _mm_set1_pd(0.5 / M_PI)), half),
                              _mm_set1_pd(static_cast<double>(earth.cols))),
                   half);
    const F64x2 v = _mm_sub_pd(_mm_mul_pd(_mm_sub_pd(half, _mm_mul_pd(lat, _mm_set1_pd(1 / M_PI))),
                                          _mm_set1_pd(static_cast<double>(earth.rows))),
                               half);
    // Bilinear(earth, u, v, true) for both lanes: floor by truncation and correction (|u|, |v|
    // are far below 2^31), then the same arithmetic.
    auto floor_pd = [&](F64x2 w) {
      const F64x2 t = TruncPd(w);
      return _mm_sub_pd(t, _mm_and_pd(_mm_cmpgt_pd(t, w), one));
    };
    const F64x2 fu = floor_pd(u), fv = floor_pd(v);
    int iu[2], iv[2];
    StoreInt2(fu, iu);
    StoreInt2(fv, iv);
    const F64x2 fx = _mm_sub_pd(u, fu), fy = _mm_sub_pd(v, fv);
    const int cols = earth.cols, rows = earth.rows;
    const float* data = reinterpret_cast<const float*>(earth.data);
    const size_t step = earth.step1();
    double t[4][2];  // texels (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1) per lane
    for (int l = 0; l < 2; ++l) {
      int xa = iu[l], xb = iu[l] + 1;
      if (static_cast<unsigned>(xa) >= static_cast<unsigned>(cols - 1)) {  // wrap (as Bilinear)
        xa = ((xa % cols) + cols) % cols;
        xb = ((xb % cols) + cols) % cols;
      }
      const int ya = iv[l], yb = iv[l] + 1;
      const float* r0 = data + step * static_cast<size_t>(std::clamp(ya, 0, rows - 1));
      const float* r1 = data + step * static_cast<size_t>(std::clamp(yb, 0, rows - 1));
      t[0][l] = r0[xa];
      t[1][l] = r0[xb];
      t[2][l] = r1[xa];
      t[3][l] = r1[xb];
    }
    auto texel = [&](int i) { return _mm_set_pd(t[i][1], t[i][0]); };
    const F64x2 gx = _mm_sub_pd(one, fx), gy = _mm_sub_pd(one, fy);
    const F64x2 value =
        _mm_add_pd(_mm_mul_pd(gy, _mm_add_pd(_mm_mul_pd(gx, texel(0)), _mm_mul_pd(fx, texel(1)))),
                   _mm_mul_pd(fy, _mm_add_pd(_mm_mul_pd(gx, texel(2)), _mm_mul_pd(fx, texel(3)))));
    alignas(16) double out[2];
    _mm_store_pd(out, _mm_mul_pd(_mm_set1_pd(scene.background.brightness), value));
    *a = out[0];
    *b = out[1];
  }

  static double Bilinear(const cv::Mat& img, double u, double v, bool wrap_x) {
    const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
    const double fx = u - x0, fy = v - y0;
    const int cols = img.cols;
    auto col = [&](int x) {
      if (!wrap_x) return std::clamp(x, 0, cols - 1);
      if (x >= 0 && x < cols) return x;
      return ((x % cols) + cols) % cols;
    };
    const int xa = col(x0), xb = col(x0 + 1);
    const float* r0 = img.ptr<float>(std::clamp(y0, 0, img.rows - 1));
    const float* r1 = img.ptr<float>(std::clamp(y0 + 1, 0, img.rows - 1));
    return (1 - fy) * ((1 - fx) * static_cast<double>(r0[xa]) + fx * static_cast<double>(r0[xb])) +
           fy * ((1 - fx) * static_cast<double>(r1[xa]) + fx * static_cast<double>(r1[xb]));
  }

  // Radiance toward the camera of a traced sample that hit a surface, lit by the frame's sun
  // unless one of `casters` blocks it.
  double Shade(const Frame& f, const Sample& smp, const std::vector<Caster>& casters) const {
    const Lighting& L = scene.light;
    const Surface& s = smp.hit.surf;
    const Vec3& n = s.normal;
    double passive = L.ambient;  // irradiance from everything but the ring light
    double spec = 0;
    if (f.sun) {
      const double cs = smp.cs;
      if (cs > 0 && !Shadowed(smp.xs, smp.sd, s.well_prim, casters, smp.prim)) {
        passive += f.sun->irradiance * cs;
        if (s.specular > 0) {
          const Vec3 hv = Normalized(smp.sd - smp.d);
          spec += s.specular * f.sun->irradiance * std::pow(std::max(0.0, Dot(n, hv)), s.shininess);
        }
      }
    }
    if (L.earthshine)
      passive += L.earthshine->irradiance * std::max(0.0, Dot(n, L.earthshine->to_sun_world));
    double radiance = s.reflectance * passive + spec;
    if (L.narrow_band_filter) radiance *= L.filter_transmission;
    if (L.ring_light > 0) {
      const Vec3 to_cam = smp.o - smp.x;
      const double r2 = Dot(to_cam, to_cam);
      const double cr = std::max(0.0, Dot(n, to_cam) / std::sqrt(r2));
      const double gain = s.retro ? s.retro_gain : 1.0;
      radiance += s.reflectance * gain * L.ring_light * cr / r2;
      if (s.specular > 0) radiance += s.specular * L.ring_light / r2 * std::pow(cr, s.shininess);
    }
    return radiance;
  }

  // Camera pose of the frame's view at fraction `tau` of the way to the next view (motion blur).
  Pose WorldFromCam(const Frame& f, double tau) const {
    if (tau <= 0 || !f.two_views) return f.cam_a;
    const double t = f.forward ? tau : -tau;
    return Pose::FromRotation(f.q_a.slerp(t, f.q_b).toRotationMatrix(),
                              (1 - t) * f.cam_a.tvec + t * f.cam_b.tvec);
  }

  Status Build();
  void BuildEarth();
  Frame MakeFrame(int view) const;
  void ConeCandidates(const Frame& f, const Vec3* c, int nc, const std::vector<Candidate>& tile,
                      std::vector<Candidate>* out, PixelPlan* plan) const;
  // The second pass of sensor.edge_rays_per_pixel over *out, the first pass's radiance:
  // `tile_candidates(tx, ty, x1, y1)` fills `candidates` for a tile.
  template <typename TileCandidates>
  void RefineEdges(const Frame& f, TileCandidates& tile_candidates,
                   const std::vector<Candidate>& candidates, cv::Mat* out) const;

  // A uniform point of the unit disc (rejection sampling: no trigonometry).
  static void SunDiscPoint(Rng* rng, double* ux, double* uy) {
    double a, b;
    do {
      a = 2 * rng->Uniform() - 1;
      b = 2 * rng->Uniform() - 1;
    } while (a * a + b * b > 1);
    *ux = a;
    *uy = b;
  }

  // The hit of a ray (world, unit `d`, from the camera) on the face of box candidate `c` that
  // `plan` says it enters through: what Intersect gives, with one division. False if the ray
  // is not inside that face after all.
  bool FaceHit(const Candidate& c, const PixelPlan& plan, const Vec3& d, LocalHit* h) const {
    const Prim& p = prims[c.prim];
    const Vec3 ld = MulT(p.R, d);
    const Vec3& lo = c.local_origin;
    const int k = plan.axis;
    if (!((ld[k] > 0) == (plan.sign < 0))) return false;
    const double t = ld[k] > 0 ? (-p.half[k] - lo[k]) / ld[k] : (p.half[k] - lo[k]) / ld[k];
    if (!(t >= kEps)) return false;
    for (int j = 0; j < 3; ++j)
      if (j != k && !(std::abs(lo[j] + t * ld[j]) < p.half[j])) return false;
    h->t = h->sort = t;
    h->n_local = Vec3::Zero();
    h->n_local[k] = plan.sign;
    h->surf = Surface{};
    h->surf.reflectance = p.material.reflectance;
    h->surf.specular = p.material.specular;
    h->surf.shininess = p.material.shininess;
    return true;
  }
  void TracePixel(const Frame& f, int x, int y, const std::vector<Candidate>& cands,
                  Sample* samples, Scratch* sc) const;
  uint64_t PixelSeed(int view, int x, int y) const {
    return scene.seed ^
           Mix((static_cast<uint64_t>(view) << 40) ^ (static_cast<uint64_t>(y) << 20) ^ x);
  }
  double RenderPixel(const Frame& f, const PixelJob& job, const std::vector<Caster>* casters,
                     Scratch* sc) const;
  void CameraRays(const Frame& f, const PixelJob& J, double* ray) const;
  double EarthPixel(const Frame& f, const PixelJob& J, double* ray) const;
  bool FacePixel(const Frame& f, const PixelJob& J, double* ray, double* radiance) const;
  bool CoveredPixel(const Frame& f, const PixelJob& J, double* ray,
                    const std::vector<Caster>* casters, Scratch* sc, double* radiance) const;
  // `self_box`: a box every sun ray at hand starts on (lit), or -1.
  // The casters one pixel's shadow rays must test: the frame's list, narrowed (into
  // sc->pixel_casters) to those that can reach a sun ray from the pixel's hit points, which lie
  // in the box [lo, hi]; `lit_prim` is the one primitive all of them are on (-1 none, -2 many).
  const std::vector<Caster>* PixelCasters(const Frame& f, Scratch* sc, bool any_sun_ray,
                                          const Vec3& lo, const Vec3& hi, int lit_prim) const {
    if (!(any_sun_ray && f.cull_casters && lo.allFinite() && hi.allFinite())) return &f.casters;
    CullCasters(f, lo, hi, &sc->pixel_casters,
                lit_prim >= 0 && prims[lit_prim].kind == Prim::Kind::kBox ? lit_prim : -1);
    return &sc->pixel_casters;
  }
  void CullCasters(const Frame& f, const Vec3& lo, const Vec3& hi, std::vector<Caster>* out,
                   int self_box) const;
  void RenderBlock(const Frame& f, int x0, int y0, int x1, int y1,
                   const std::vector<Candidate>& candidates, Scratch* scratch, cv::Mat* out) const;
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;
const Scene& Renderer::scene() const { return impl_->scene; }

Status Renderer::Create(const Scene& scene, std::unique_ptr<Renderer>* out) {
  if (Status s = scene.Validate(); !s) return s;
  std::unique_ptr<Renderer> r(new Renderer());
  r->impl_->scene = scene;
  if (Status s = r->impl_->Build(); !s) return s;
  *out = std::move(r);
  return Status::Ok();
}

Status Renderer::Impl::Build() {
  // Directions toward the sun must be unit vectors (the JSON parser normalises them; scenes
  // built in code may not).
  auto unit = [](std::optional<Sun>& sun) -> bool {
    if (!sun) return true;
    const double n = sun->to_sun_world.norm();
    if (!(n > 1e-12) || !sun->to_sun_world.allFinite()) return false;
    sun->to_sun_world /= n;
    return true;
  };
  if (!unit(scene.light.sun))
    return Status::Error("light.sun.to_sun: expected a nonzero direction");
  if (!unit(scene.light.earthshine))
    return Status::Error("light.earthshine.to_sun: expected a nonzero direction");
  for (size_t v = 0; v < scene.views.size(); ++v)
    if (!unit(scene.views[v].sun))
      return Status::Error("views[" + std::to_string(v) +
                           "].sun.to_sun: expected a nonzero direction");
  if (!ValidEdgeRays(scene.sensor))
    return Status::Error(
        "sensor.edge_rays_per_pixel: expected 0 (off), or a square number of at "
        "most 4096, got " +
        std::to_string(scene.sensor.edge_rays_per_pixel));
  W = scene.camera.width();
  H = scene.camera.height();
  // Pixel-corner rays: corner (i, j) is the pixel coordinate (i - 0.5, j - 0.5).
  std::vector<Eigen::Vector2d> px;
  px.reserve(static_cast<size_t>(W + 1) * (H + 1));
  for (int j = 0; j <= H; ++j)
    for (int i = 0; i <= W; ++i) px.emplace_back(i - 0.5, j - 0.5);
  std::vector<Vec3> dirs;
  corner_dirs.assign(px.size(), Eigen::Vector3f::Constant(NAN));
  if (scene.camera.UnprojectMany(px, &dirs)) {
    for (size_t k = 0; k < px.size(); ++k) corner_dirs[k] = dirs[k].cast<float>();
  } else {
    // Some corners do not unproject (e.g. outside a wide lens's valid region): do them one by
    // one; pixels touching an invalid corner render as background.
    int bad = 0;
    for (size_t k = 0; k < px.size(); ++k) {
      Vec3 dd;
      if (scene.camera.Unproject(px[k], &dd) && dd.allFinite()) {
        corner_dirs[k] = dd.cast<float>();
      } else {
        ++bad;
      }
    }
    if (bad == static_cast<int>(px.size()))
      return Status::Error("camera: mrcal cannot unproject any pixel of " + scene.camera.Summary());
  }

  // Static geometry.
  for (const SceneObject& o : scene.objects) {
    Prim p;
    p.kind = o.shape == SceneObject::Shape::kBox ? Prim::Kind::kBox : Prim::Kind::kPlane;
    p.R = o.world_from_object.Rotation();
    p.t = o.world_from_object.tvec;
    p.half = 0.5 * o.size;
    if (p.kind == Prim::Kind::kPlane) p.half.z() = 0;
    p.material = o.material;
    p.centre = p.t;
    p.radius = p.half.norm() * (1 + 1e-9) + 1e-9;
    prims.push_back(p);
    for (const SceneMarker& sm : o.markers) {
      Prim mp;
      mp.kind = Prim::Kind::kMarker;
      const Pose world_from_marker = o.world_from_object * sm.object_from_marker;
      mp.R = world_from_marker.Rotation();
      mp.t = world_from_marker.tvec;
      mp.marker = &sm;
      mp.word = sm.print.peer() ? 0 : Svms44::Codeword(sm.model.id);
      if (sm.model.inner) mp.inner_word = Svms44::Codeword(sm.model.inner->id);
      if (sm.model.post) {
        mp.has_post = true;
        mp.post_h = sm.model.post->height;
        mp.post_r = sm.model.post->radius;
        mp.tip_r = sm.model.post->tip_radius;
      }
      mp.centre = mp.t;
      const double e = sm.model.half_extent();
      mp.radius = std::sqrt(2 * e * e + mp.post_h * mp.post_h) * (1 + 1e-9) + 1e-9;
      mp.casts_shadow = mp.has_post && mp.post_h > 0;
      mp.decal_half = e;
      if (mp.casts_shadow) {
        mp.post_centre = mp.t + mp.R.col(2) * (0.5 * mp.post_h);
        mp.post_radius = std::hypot(mp.post_r, 0.5 * mp.post_h) * (1 + 1e-9) + 1e-9;
      }
      prims.push_back(mp);
    }
  }
  const size_t n_static = prims.size();
  auto add_occluders = [&](const std::vector<Occluder>& occ) {
    std::vector<int> idx;
    for (const Occluder& o : occ) {
      Prim p;
      p.kind = o.shape == Occluder::Shape::kBar ? Prim::Kind::kBox : Prim::Kind::kSphere;
      p.R = o.world_from_occluder.Rotation();
      p.t = o.world_from_occluder.tvec;
      p.half = o.shape == Occluder::Shape::kBar ? Vec3(0.5 * o.size) : Vec3(o.size.x(), 0, 0);
      p.material.reflectance = o.reflectance;
      p.centre = p.t;
      p.radius =
          (o.shape == Occluder::Shape::kBar ? p.half.norm() : o.size.x()) * (1 + 1e-9) + 1e-9;
      idx.push_back(static_cast<int>(prims.size()));
      prims.push_back(p);
    }
    return idx;
  };
  const std::vector<int> shared = add_occluders(scene.occluders);
  view_prims.resize(scene.views.size());
  for (size_t v = 0; v < scene.views.size(); ++v) {
    for (size_t i = 0; i < n_static; ++i) view_prims[v].push_back(static_cast<int>(i));
    const std::vector<int> occ =
        scene.views[v].occluders ? add_occluders(*scene.views[v].occluders) : shared;
    view_prims[v].insert(view_prims[v].end(), occ.begin(), occ.end());
  }
  // Marker pointers refer into scene.objects, which no longer changes.
  if (scene.background.kind == Background::Kind::kEarth) BuildEarth();
  if (scene.background.kind == Background::Kind::kImage) {
    const cv::Mat img =
        cv::imread(scene.background.image_path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
    if (img.empty())
      return Status::Error("background.image: " + scene.background.image_path +
                           ": cannot read as an image");
    cv::Mat f;
    img.convertTo(f, CV_32F, img.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255);
    cv::resize(f, backdrop, cv::Size(W, H), 0, 0, cv::INTER_AREA);
  }
  return Status::Ok();
}

// A procedural earth seen from orbit: fractal value noise over the sphere, thresholded into
// dark sea and bright cloud, grey. Deterministic from the scene seed.
//
// The texels along a row mostly share their lattice cells (all but the finest octaves change
// cell every few texels at most), so each octave keeps the hashed values of the last cell it
// used; the trigonometry is tabulated per row and column. The values are the same to the bit
// as evaluating every texel from scratch.
void Renderer::Impl::BuildEarth() {
  const int w = 2048, h = 1024;
  constexpr int kOctaves = 6;
  earth.create(h, w, CV_32F);
  const uint64_t seed = Mix(scene.seed ^ 0xea57ULL);
  auto lattice = [&](int64_t x, int64_t y, int64_t z) {
    return (Mix(seed ^ Mix(x * 73856093LL ^ Mix(y * 19349663LL ^ Mix(z * 83492791LL)))) >> 11) *
           0x1.0p-53;
  };
  auto smooth = [](double t) { return t * t * (3 - 2 * t); };
  struct Cell {
    int64_t x = 0, y = 0, z = 0;
    bool valid = false;
    double value[8];
  };
  Cell cells[kOctaves];
  // floor, exactly, for |w| < 2^52 (here |w| < 130).
  auto floor_small = [](double w) {
    const double t = static_cast<double>(static_cast<int64_t>(w));
    return t > w ? t - 1 : t;
  };
  auto noise = [&](const Vec3& p, Cell* cell) {
    const Vec3 f(floor_small(p.x()), floor_small(p.y()), floor_small(p.z()));
    const Vec3 r = p - f;
    const int64_t x = static_cast<int64_t>(f.x()), y = static_cast<int64_t>(f.y()),
                  z = static_cast<int64_t>(f.z());
    if (!cell->valid || cell->x != x || cell->y != y || cell->z != z) {
      for (int k = 0; k < 8; ++k) {
        const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
        cell->value[k] = lattice(x + dx, y + dy, z + dz);
      }
      cell->x = x;
      cell->y = y;
      cell->z = z;
      cell->valid = true;
    }
    // The weights (dx ? sx : 1 - sx) * (dy ? sy : 1 - sy) * (dz ? sz : 1 - sz), summed in k order.
    const double sx = smooth(r.x()), sy = smooth(r.y()), sz = smooth(r.z());
    const double ux = 1 - sx, uy = 1 - sy, uz = 1 - sz;
    const double w00 = ux * uy, w10 = sx * uy, w01 = ux * sy, w11 = sx * sy;
    const double* l = cell->value;
    double v = 0;
    v += w00 * uz * l[0];
    v += w10 * uz * l[1];
    v += w01 * uz * l[2];
    v += w11 * uz * l[3];
    v += w00 * sz * l[4];
    v += w10 * sz * l[5];
    v += w01 * sz * l[6];
    v += w11 * sz * l[7];
    return v;
  };
  std::vector<double> cos_lon(w), sin_lon(w);
  for (int i = 0; i < w; ++i) {
    const double lon = 2 * M_PI * ((i + 0.5) / w - 0.5);
    cos_lon[i] = std::cos(lon);
    sin_lon[i] = std::sin(lon);
  }
  for (int j = 0; j < h; ++j) {
    const double lat = M_PI * (0.5 - (j + 0.5) / h);
    const double cos_lat = std::cos(lat), sin_lat = std::sin(lat);
    float* row = earth.ptr<float>(j);
    for (int i = 0; i < w; ++i) {
      const Vec3 p(cos_lat * cos_lon[i], cos_lat * sin_lon[i], sin_lat);
      double v = 0, amp = 0.5, freq = 3;
      for (int o = 0; o < kOctaves; ++o, amp *= 0.5, freq *= 2.1)
        v += amp * noise(p * freq, &cells[o]);
      const double cloud = std::clamp((v - 0.45) * 4, 0.0, 1.0);
      row[i] = static_cast<float>(0.12 + 0.08 * v + 0.8 * cloud);
    }
  }
}

Renderer::Impl::Frame Renderer::Impl::MakeFrame(int view) const {
  Frame f;
  f.view = view;
  f.n = static_cast<int>(std::lround(std::sqrt(scene.sensor.rays_per_pixel)));
  f.sun = SunOf(view);
  if (f.sun) {
    const Vec3& s = f.sun->to_sun_world;
    f.t1 = s.unitOrthogonal();
    f.t2 = s.cross(f.t1);
    f.sun_r = 0.5 * f.sun->angular_diameter_deg * M_PI / 180;
    f.sun_centre_dir = Normalized(s);
    // Sun rays: normalize(s + sun_r (ux t1 + uy t2)), ux^2 + uy^2 <= 1, |t1| = 1, |t2| = |s|:
    // within asin(offset / |s|) of s.
    const double len = s.norm(), offset = f.sun_r * std::max(1.0, len);
    if (std::isfinite(len) && len > 0 && offset < 0.5 * len) {
      f.cull_casters = true;
      f.to_sun = s / len;
      f.sun_spread = std::asin(offset / len) * (1 + 1e-6) + 1e-12;
    }
  }
  f.moving = scene.sensor.motion_blur > 0;
  f.cam_a = scene.views[view].cam_from_world.Inverse();
  f.o = f.cam_a.tvec;
  f.Rwc = f.cam_a.Rotation();
  if (scene.views.size() >= 2) {
    f.two_views = true;
    f.forward = view + 1 < static_cast<int>(scene.views.size());
    f.cam_b = scene.views[f.forward ? view + 1 : view - 1].cam_from_world.Inverse();
    f.q_a = Eigen::Quaterniond(f.cam_a.Rotation());
    f.q_b = Eigen::Quaterniond(f.cam_b.Rotation());
  }
  f.casters = Casters(view, f.sun);
  return f;
}

// Of a tile's candidates, those that some ray through the pixels whose corner rays (world,
// unit) are c[0..nc) may hit. A pixel's rays are blends of its four corner rays with
// non-negative weights (in float: within 1e-6 rad of their convex cone), so a primitive whose
// bounding sphere is outside the cone of the corner rays (widened by 2e-6 rad) cannot be hit;
// nor a marker's decal whose square is outside the polygon where the corner rays meet its plane
// (rays in the cone meet the plane inside it), unless its post may be hit.
//
// Also finds a box that every ray of the pixel enters through the inside of one face (the four
// corner rays do, 1e-4 of their length inside its edges): then every sample hits something.
void Renderer::Impl::ConeCandidates(const Frame& f, const Vec3* c, int nc,
                                    const std::vector<Candidate>& tile, std::vector<Candidate>* out,
                                    PixelPlan* plan) const {
  out->clear();
  *plan = PixelPlan{};
  if (tile.empty()) return;
  Vec3 axis = Vec3::Zero();
  for (int i = 0; i < nc; ++i) axis += c[i];
  axis = Normalized(axis);
  double cos_t = 1;
  for (int i = 0; i < nc; ++i) cos_t = std::min(cos_t, Dot(axis, c[i]));
  constexpr double kWiden = 2e-6;
  const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
  const double cos_m = cos_t - kWiden * sin_t - kWiden * kWiden,
               sin_m = std::sqrt(std::max(0.0, 1 - cos_m * cos_m));
  if (!(cos_m > 0.5)) {  // not a pixel-sized cone (or NaN): keep everything
    *out = tile;
    return;
  }
  // True if all corner rays enter box `p` through face `axis` well inside its edges.
  auto covers = [&](const Prim& p, const Vec3& lo, int* axis, double* sign) {
    double t_max = 0, inside = INFINITY;
    plan->foot_lo = Vec3::Constant(INFINITY);
    plan->foot_hi = Vec3::Constant(-INFINITY);
    for (int i = 0; i < nc; ++i) {
      const Vec3 ld = MulT(p.R, c[i]);
      LocalHit h;
      if (!Intersect(p, lo, ld, &h)) return false;
      int k = 0;
      while (k < 3 && h.n_local[k] == 0) ++k;
      if (k == 3) return false;
      if (i == 0) {
        *axis = k;
        *sign = h.n_local[k];
      } else if (k != *axis || h.n_local[k] != *sign) {
        return false;
      }
      if (!(std::abs(ld[k]) >= 0.02)) return false;  // grazing
      const Vec3 q = lo + h.t * ld;
      for (int j = 0; j < 3; ++j)
        if (j != k) inside = std::min(inside, p.half[j] - std::abs(q[j]));
      t_max = std::max(t_max, h.t);
      const Vec3 world = f.o + h.t * c[i];
      plan->foot_lo = plan->foot_lo.cwiseMin(world);
      plan->foot_hi = plan->foot_hi.cwiseMax(world);
    }
    plan->foot_t = t_max;
    return inside >= 1e-4 * t_max + 1e-9;
  };
  // True if the sphere (centre, radius) may meet the cone.
  auto sphere = [&](const Vec3& centre, double radius) {
    const Vec3 v = centre - f.o;
    const double dist = std::sqrt(Dot(v, v));
    if (dist <= radius) return true;
    const double sin_b = radius / dist, cos_b = std::sqrt(std::max(0.0, 1 - sin_b * sin_b));
    return Dot(axis, v) >= dist * (cos_m * cos_b - sin_m * sin_b) - 1e-12 * dist;
  };
  // The cone's rays within distance T of the camera are within T * theta of its axis.
  const double theta = 1.5708 * sin_m;  // >= the angle (< 60 degrees)
  for (const Candidate& cand : tile) {
    const Prim& p = prims[cand.prim];
    if (!sphere(p.centre, p.radius)) continue;
    if (p.kind == Prim::Kind::kBox) {
      // A ray of the cone hitting the box does so at t <= T (the far side of its bounding
      // sphere), so the axis ray passes through the box grown by T * theta on every side.
      const double grow =
          (std::sqrt(Dot(p.centre - f.o, p.centre - f.o)) + p.radius) * theta * (1 + 1e-6) + 1e-9;
      const Vec3 la = MulT(p.R, axis);
      const Vec3& lo = cand.local_origin;
      double tn = 0, tf = INFINITY;
      for (int k = 0; k < 3 && tn <= tf; ++k) {
        const double h = p.half[k] + grow;
        if (std::abs(la[k]) < 1e-300) {
          if (std::abs(lo[k]) > h) tn = INFINITY;
          continue;
        }
        double a = (-h - lo[k]) / la[k], b = (h - lo[k]) / la[k];
        if (a > b) std::swap(a, b);
        tn = std::max(tn, a);
        tf = std::min(tf, b);
      }
      if (tn <= tf) {
        if (plan->cover < 0 && covers(p, lo, &plan->axis, &plan->sign))
          plan->cover = static_cast<int>(out->size());
        out->push_back(cand);
      }
      continue;
    }
    if (p.kind != Prim::Kind::kMarker) {
      out->push_back(cand);
      continue;
    }
    // The post (a well is entered through the decal).
    if (p.has_post && p.post_h > 0 && sphere(p.post_centre, p.post_radius)) {
      out->push_back(cand);
      continue;
    }
    Candidate decal_only = cand;
    decal_only.no_post = true;
    // The decal: seen only from its front (camera at local z > 0, rays with local z < 0).
    const Vec3& lo = cand.local_origin;
    if (!(lo.z() > 0)) continue;
    bool decal = false, away = true;
    double qx0 = INFINITY, qx1 = -INFINITY, qy0 = INFINITY, qy1 = -INFINITY, t_max = 0;
    for (int i = 0; i < nc; ++i) {
      const Vec3 ld = MulT(p.R, c[i]);
      if (ld.z() < 1e-5) away = false;
      if (!(ld.z() < -0.02)) {  // grazing or away: no useful footprint
        decal = true;
        continue;
      }
      const double t = -lo.z() / ld.z();
      qx0 = std::min(qx0, lo.x() + t * ld.x());
      qx1 = std::max(qx1, lo.x() + t * ld.x());
      qy0 = std::min(qy0, lo.y() + t * ld.y());
      qy1 = std::max(qy1, lo.y() + t * ld.y());
      t_max = std::max(t_max, t);
    }
    if (away) continue;  // every ray leaves the decal's plane away from it
    if (!decal) {
      const double e = p.decal_half + 1e-4 * t_max + 1e-9;
      decal = qx1 >= -e && qx0 <= e && qy1 >= -e && qy0 <= e;
    }
    if (decal) out->push_back(decal_only);
  }
  if (plan->cover >= 0) {
    const Prim& p = prims[(*out)[plan->cover].prim];
    plan->face_only = out->size() == 1 && p.material.pattern.kind == Pattern::Kind::kUniform;
  }
}

// Renders pixels [x0, x1) x [y0, y1) (inside one culling tile).
//
// Each pixel's random numbers are drawn in one fixed order (per sample: jitter, the
// motion-blur time, then the sun disc if the ray hit something), and only that order ties its
// samples together. Most pixels are "planned": no candidate can be hit (every sample sees the
// background), or a box face covers the pixel (every sample hits something), so which numbers
// each sample takes is known before tracing. Their numbers are drawn first (a row of the
// block at a time, the generators interleaved), and the rest runs in loops whose iterations are
// independent, two samples at a time in SSE2 lanes where that helps (camera rays, background,
// sun rays). The other pixels are traced one sample after another. The shadow casters that no
// sun ray of the block (if one box face covers it) or else of the pixel can reach are dropped
// before shading.
void Renderer::Impl::RenderBlock(const Frame& f, int x0, int y0, int x1, int y1,
                                 const std::vector<Candidate>& candidates, Scratch* sc,
                                 cv::Mat* out) const {
  const int n = f.n, nn = n * n;
  const int bw = x1 - x0, bh = y1 - y0;
  auto corner = [&](int x, int y) -> const Eigen::Vector3f& {
    return corner_dirs[static_cast<size_t>(y) * (W + 1) + x];
  };

  // What the block's rays may hit (all its pixels' corner rays bound them): often nothing, or
  // only one face of a box; else each pixel is looked at on its own.
  PixelPlan block_plan;
  const int gw = bw + 1;
  sc->block_cands.clear();
  if (!f.moving) {
    sc->grid.resize(static_cast<size_t>(gw) * (bh + 1));
    for (int j = 0; j <= bh; ++j)
      for (int i = 0; i <= bw; ++i)
        sc->grid[j * gw + i] = Normalized(Mul(f.Rwc, corner(x0 + i, y0 + j).cast<double>()));
    ConeCandidates(f, sc->grid.data(), static_cast<int>(sc->grid.size()), candidates,
                   &sc->block_cands, &block_plan);
  }
  const bool block_planned = !f.moving && (sc->block_cands.empty() || block_plan.face_only);
  // A block on one face: its sun rays start near where its corner rays meet the face.
  bool block_casters = false;
  if (block_planned && block_plan.face_only && f.sun && f.cull_casters) {
    const double grow = 1e-4 * block_plan.foot_t + 2 * kShadowOffset + 1e-9;
    CullCasters(f, block_plan.foot_lo - Vec3::Constant(grow),
                block_plan.foot_hi + Vec3::Constant(grow), &sc->block_casters,
                sc->block_cands[block_plan.cover].prim);
    block_casters = true;
  }

  sc->samples.resize(kGroup * static_cast<size_t>(nn));
  for (int y = y0; y < y1; ++y) {
    float* row = out->ptr<float>(y);
    for (int xp = x0; xp < x1; xp += kGroup) {
      // kGroup pixels at a time (fewer at the block's edge).
      PixelJob job[kGroup];
      const int count = std::min(kGroup, x1 - xp);
      for (int j = 0; j < count; ++j) {
        PixelJob& J = job[j];
        J.x = xp + j;
        J.y = y;
        J.samples = &sc->samples[j * static_cast<size_t>(nn)];
        J.cands = block_planned ? &sc->block_cands : &sc->pixel_cands[j];
        const int x = J.x;
        J.valid = corner(x, y).allFinite() && corner(x + 1, y).allFinite() &&
                  corner(x, y + 1).allFinite() && corner(x + 1, y + 1).allFinite();
        if (!J.valid) continue;  // stays 0
        if (block_planned) {
          J.plan = block_plan;
          J.plan.planned = true;
          continue;
        }
        J.plan = PixelPlan{};
        J.cands->clear();
        if (!f.moving) {
          const int gi = (y - y0) * gw + (x - x0);
          const Vec3 c[4] = {sc->grid[gi], sc->grid[gi + 1], sc->grid[gi + gw],
                             sc->grid[gi + gw + 1]};
          ConeCandidates(f, c, 4, sc->block_cands, J.cands, &J.plan);
          J.plan.planned = J.cands->empty() || J.plan.cover >= 0;
        }
      }
      // The planned pixels' random numbers, their generators interleaved.
      {
        Rng rng[kGroup];
        bool draw[kGroup] = {}, hit_all[kGroup] = {};
        for (int j = 0; j < count; ++j) {
          draw[j] = job[j].valid && job[j].plan.planned;
          if (draw[j]) rng[j] = Rng(PixelSeed(f.view, job[j].x, job[j].y));
          hit_all[j] = draw[j] && !job[j].cands->empty() && f.sun;
        }
        const bool n_pow2 = (n & (n - 1)) == 0;
        const double inv_n = 1.0 / n;
        for (int sy = 0, k = 0; sy < n; ++sy) {
          for (int sx = 0; sx < n; ++sx, ++k) {
            for (int j = 0; j < kGroup; ++j) {
              if (!draw[j]) continue;
              Sample& smp = job[j].samples[k];
              const double jx = sx + rng[j].Uniform();
              smp.px = n_pow2 ? jx * inv_n : jx / n;  // fx for now
              const double jy = sy + rng[j].Uniform();
              smp.py = n_pow2 ? jy * inv_n : jy / n;  // fy for now
              if (hit_all[j]) SunDiscPoint(&rng[j], &smp.ux, &smp.uy);
            }
          }
        }
      }
      for (int j = 0; j < count; ++j) {
        if (!job[j].valid) continue;
        const double v = RenderPixel(f, job[j], block_casters ? &sc->block_casters : nullptr, sc);
        row[job[j].x] = static_cast<float>(v);
      }
    }
  }
}

// The camera rays (world, unit) of planned pixel J's samples (their jitter in px, py) into
// ray[0..nn) (x), ray[nn+2..) (y), ray[2 (nn+2)..) (z): Blend's float arithmetic in the lanes
// of one SSE register, then Normalized and Mul two samples at a time. With nn odd, ray nn
// repeats ray nn - 1 (so pairs can always be loaded whole).
void Renderer::Impl::CameraRays(const Frame& f, const PixelJob& J, double* ray) const {
  const int nn = f.n * f.n, stride = nn + 2;
  const size_t i = static_cast<size_t>(J.y) * (W + 1) + J.x;
  auto load = [&](const Eigen::Vector3f& c) { return _mm_setr_ps(c[0], c[1], c[2], 0.0f); };
  const F32x4 c00 = load(corner_dirs[i]), c10 = load(corner_dirs[i + 1]),
              c01 = load(corner_dirs[i + W + 1]), c11 = load(corner_dirs[i + W + 2]);
  auto blend = [&](const Sample& s) {
    const F32x4 a = _mm_set1_ps(static_cast<float>(1 - s.py)),
                b = _mm_set1_ps(static_cast<float>(1 - s.px)),
                c = _mm_set1_ps(static_cast<float>(s.px)),
                e = _mm_set1_ps(static_cast<float>(s.py));
    return _mm_add_ps(_mm_mul_ps(a, _mm_add_ps(_mm_mul_ps(b, c00), _mm_mul_ps(c, c10))),
                      _mm_mul_ps(e, _mm_add_ps(_mm_mul_ps(b, c01), _mm_mul_ps(c, c11))));
  };
  for (int k = 0; k < nn; k += 2) {
    const F32x4 ra = blend(J.samples[k]), rb = blend(J.samples[k + 1 < nn ? k + 1 : k]);
    const F64x2 a_xy = _mm_cvtps_pd(ra), b_xy = _mm_cvtps_pd(rb);
    const F64x2 a_z = _mm_cvtps_pd(_mm_movehl_ps(ra, ra)),
                b_z = _mm_cvtps_pd(_mm_movehl_ps(rb, rb));
    const V2 d =
        Mul2(f.Rwc, Normalized2(V2{_mm_unpacklo_pd(a_xy, b_xy), _mm_unpackhi_pd(a_xy, b_xy),
                                   _mm_unpacklo_pd(a_z, b_z)}));
    _mm_storeu_pd(ray + k, d.x);
    _mm_storeu_pd(ray + stride + k, d.y);
    _mm_storeu_pd(ray + 2 * stride + k, d.z);
  }
}

// A planned pixel that sees only the earth: RenderPixel's arithmetic, without its records.
double Renderer::Impl::EarthPixel(const Frame& f, const PixelJob& J, double* ray) const {
  const int nn = f.n * f.n, stride = nn + 2;
  CameraRays(f, J, ray);
  const double *rx = ray, *ry = ray + stride, *rz = ray + 2 * stride;
  double sum = 0;
  const EarthRef ref = MakeEarthRef(Vec3(rx[0], ry[0], rz[0]));
  for (int k = 0; k < nn; k += 2) {
    const int k2 = k + 1 < nn ? k + 1 : k;
    const V2 d{_mm_loadu_pd(rx + k), _mm_loadu_pd(ry + k),
               _mm_loadu_pd(rz + k)};  // (k2: the same ray)
    double va, vb;
    EarthNear2(ref, d, &va, &vb);
    sum += va;
    if (k2 != k) sum += vb;
  }
  return sum / nn;
}

// A planned pixel on one face of a box, matte, lit by sun and ambient only, with no shadow
// caster: RenderPixel's arithmetic, without its records. False (nothing done) if a ray does
// not hit the face as planned (which cannot happen).
bool Renderer::Impl::FacePixel(const Frame& f, const PixelJob& J, double* ray,
                               double* radiance) const {
  const int nn = f.n * f.n, stride = nn + 2;
  const Sample* samples = J.samples;
  CameraRays(f, J, ray);
  const double *rx = ray, *ry = ray + stride, *rz = ray + 2 * stride;
  const Candidate& c = (*J.cands)[0];
  const Prim& p = prims[c.prim];
  const int k = J.plan.axis;
  const double sign = J.plan.sign;
  Vec3 n_local = Vec3::Zero();
  n_local[k] = sign;
  const Vec3 nrm = Mul(p.R, n_local);
  const V2 n2 = Load2(nrm, nrm);
  // FaceHit: t = (-half - lo) / ld for rays entering the face at -half (ld > 0), else (half - lo) /
  // ld.
  const F64x2 num =
      _mm_set1_pd(sign < 0 ? -p.half[k] - c.local_origin[k] : p.half[k] - c.local_origin[k]);
  const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  const F64x2 lo1 = _mm_set1_pd(c.local_origin[k1]), lo2 = _mm_set1_pd(c.local_origin[k2]);
  const F64x2 h1 = _mm_set1_pd(p.half[k1]), h2 = _mm_set1_pd(p.half[k2]),
              abs_mask = _mm_set1_pd(-0.0);
  auto col = [&](int j, const V2& d) {  // (R^T d)[j], as MulT
    return _mm_add_pd(_mm_add_pd(_mm_mul_pd(_mm_set1_pd(p.R(0, j)), d.x),
                                 _mm_mul_pd(_mm_set1_pd(p.R(1, j)), d.y)),
                      _mm_mul_pd(_mm_set1_pd(p.R(2, j)), d.z));
  };
  const double refl = p.material.reflectance, ambient = scene.light.ambient;
  const Vec3& s = f.sun ? f.sun->to_sun_world : Vec3::Zero().eval();
  const F64x2 r_sun = _mm_set1_pd(f.sun_r);
  double sum = 0;
  for (int i = 0; i < nn; i += 2) {
    const int i2 = i + 1 < nn ? i + 1 : i;
    const Sample& a = samples[i];
    const Sample& b = samples[i2];
    const V2 d{_mm_loadu_pd(rx + i), _mm_loadu_pd(ry + i),
               _mm_loadu_pd(rz + i)};  // (i2: the same ray)
    const F64x2 ldk = col(k, d);
    const F64x2 entering =
        sign < 0 ? _mm_cmpgt_pd(ldk, _mm_setzero_pd()) : _mm_cmple_pd(ldk, _mm_setzero_pd());
    const F64x2 t = _mm_div_pd(num, ldk);
    const F64x2 in1 =
        _mm_cmplt_pd(_mm_andnot_pd(abs_mask, _mm_add_pd(lo1, _mm_mul_pd(t, col(k1, d)))), h1);
    const F64x2 in2 =
        _mm_cmplt_pd(_mm_andnot_pd(abs_mask, _mm_add_pd(lo2, _mm_mul_pd(t, col(k2, d)))), h2);
    const F64x2 facing = _mm_cmple_pd(Dot2(n2, d), _mm_setzero_pd());  // no flip of the normal
    const F64x2 good = _mm_and_pd(
        _mm_and_pd(_mm_and_pd(entering, _mm_cmpge_pd(t, _mm_set1_pd(kEps))), _mm_and_pd(in1, in2)),
        facing);
    if (_mm_movemask_pd(good) != 3) return false;
    double va = refl * ambient + 0.0, vb = va;
    if (f.sun) {
      V2 sd;
      if (f.sun_r == 0) {
        sd = Load2(f.sun_centre_dir, f.sun_centre_dir);
      } else {
        const F64x2 ca = _mm_mul_pd(r_sun, _mm_set_pd(b.ux, a.ux)),
                    cb = _mm_mul_pd(r_sun, _mm_set_pd(b.uy, a.uy));
        auto comp = [&](int j) {
          return _mm_add_pd(_mm_add_pd(_mm_set1_pd(s[j]), _mm_mul_pd(ca, _mm_set1_pd(f.t1[j]))),
                            _mm_mul_pd(cb, _mm_set1_pd(f.t2[j])));
        };
        sd = Normalized2(V2{comp(0), comp(1), comp(2)});
      }
      const F64x2 cs = Dot2(n2, sd);
      const F64x2 amb = _mm_set1_pd(ambient);
      const F64x2 lit = _mm_cmpgt_pd(cs, _mm_setzero_pd());
      const F64x2 passive = _mm_or_pd(
          _mm_and_pd(lit, _mm_add_pd(amb, _mm_mul_pd(_mm_set1_pd(f.sun->irradiance), cs))),
          _mm_andnot_pd(lit, amb));
      alignas(16) double v[2];
      _mm_store_pd(v, _mm_add_pd(_mm_mul_pd(_mm_set1_pd(refl), passive), _mm_setzero_pd()));
      va = v[0];
      vb = v[1];
    }
    sum += va;
    if (i2 != i) sum += vb;
  }
  *radiance = sum / nn;
  return true;
}

// A planned pixel covered by a box face whose other candidates are marker decals (no post, no
// well in reach), matte, lit by sun and ambient only: what Nearest, Intersect and Shade do for
// it, without their records. False (nothing done) if a ray does something else (a well).
bool Renderer::Impl::CoveredPixel(const Frame& f, const PixelJob& J, double* ray,
                                  const std::vector<Caster>* casters, Scratch* sc,
                                  double* radiance) const {
  const int nn = f.n * f.n, stride = nn + 2;
  if (nn > kMaxFused) return false;
  const std::vector<Candidate>& cands = *J.cands;
  const PixelPlan& plan = J.plan;
  const Sample* samples = J.samples;
  struct Decal {
    const Prim* p;
    const Candidate* c;
    Vec3 nrm;  // world normal of the decal (local +z)
  };
  Decal decals[8];
  int n_decals = 0;
  for (size_t i = 0; i < cands.size(); ++i) {
    if (static_cast<int>(i) == plan.cover) continue;
    const Prim& p = prims[cands[i].prim];
    if (p.kind != Prim::Kind::kMarker || !(cands[i].no_post || !(p.has_post && p.post_h > 0)) ||
        n_decals == 8)
      return false;
    decals[n_decals++] = {&p, &cands[i], Mul(p.R, Vec3(0, 0, 1))};
  }
  const Candidate& bc = cands[plan.cover];
  const Prim& box = prims[bc.prim];
  const int k = plan.axis, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  const double sign = plan.sign;
  Vec3 n_local = Vec3::Zero();
  n_local[k] = sign;
  const Vec3 box_nrm = Mul(box.R, n_local);
  const double num =
      sign < 0 ? -box.half[k] - bc.local_origin[k] : box.half[k] - bc.local_origin[k];
  CameraRays(f, J, ray);
  const double *rx = ray, *ry = ray + stride, *rz = ray + 2 * stride;
  // Per sample: what it hit (index into cands), its distance, reflectance and normal.
  int hit_c[kMaxFused];
  double hit_t[kMaxFused], refl[kMaxFused];
  const Vec3* hit_n[kMaxFused];
  for (int s = 0; s < nn; ++s) {
    const Vec3 d(rx[s], ry[s], rz[s]);
    double best_sort = 1e300;
    int decal_i = 0;
    hit_c[s] = -1;
    for (size_t i = 0; i < cands.size(); ++i) {
      if (static_cast<int>(i) == plan.cover) {
        // FaceHit
        const Vec3 ld = MulT(box.R, d);
        if (!((ld[k] > 0) == (sign < 0))) return false;
        const double t = num / ld[k];
        if (!(t >= kEps)) return false;
        if (!(std::abs(bc.local_origin[k1] + t * ld[k1]) < box.half[k1]) ||
            !(std::abs(bc.local_origin[k2] + t * ld[k2]) < box.half[k2]))
          return false;
        if (t < best_sort) {
          best_sort = t;
          hit_c[s] = static_cast<int>(i);
          hit_t[s] = t;
          refl[s] = box.material.reflectance;
          hit_n[s] = &box_nrm;
        }
        continue;
      }
      const Decal& dc = decals[decal_i++];
      const Prim& p = *dc.p;
      // Nearest's bounding-sphere rejection, then IntersectMarker's decal.
      const Vec3 oc = p.centre - f.o;
      const double along = Dot(oc, d);
      if (along < -p.radius) continue;
      if (PerpSquared(oc, along, d) > p.radius * p.radius) continue;
      const Vec3 ld = MulT(p.R, d);
      if (!(ld.z() < 0)) continue;
      const Vec3& lo = dc.c->local_origin;
      const double t0 = -lo.z() / ld.z();
      if (!(t0 > kEps && t0 - kCoplanarWin < 1e300)) continue;
      const Vec3 q = lo + t0 * ld;
      const double rho2 = q.x() * q.x() + q.y() * q.y();
      if (p.has_post && p.post_h < 0 && rho2 < p.post_r * p.post_r) return false;  // into a well
      const MarkerModel& m = p.marker->model;
      bool inside = false, white;
      if (p.marker->print.peer()) {
        white = PeerWhite(q.x(), q.y(), m.size, p.decal_half, p.marker->print, &inside);
      } else if (m.inner && InsideSquare(q.x(), q.y(), 6 * m.inner->cell_size)) {
        white = RingWhite(q.x(), q.y(), m.inner->size, m.inner->cell_size, p.inner_word, &inside);
      } else {
        white = RingWhite(q.x(), q.y(), m.size, m.cell_size, p.word, &inside);
      }
      if (!inside) continue;
      const double sort = t0 - kCoplanarWin;
      if (sort < best_sort) {
        best_sort = sort;
        hit_c[s] = static_cast<int>(i);
        hit_t[s] = t0;
        refl[s] = white ? p.marker->white : p.marker->black;
        hit_n[s] = &dc.nrm;
      }
    }
    if (hit_c[s] < 0) return false;  // the box face is hit: cannot happen
  }
  // Normals, hit points, sun rays; the bounds of the lit ones (for the casters).
  Vec3 nrm[kMaxFused], xs[kMaxFused], sd[kMaxFused];
  double cs[kMaxFused];
  bool any_sun_ray = false;
  int lit_prim = -1;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (int s = 0; s < nn; ++s) {
    const Vec3 d(rx[s], ry[s], rz[s]);
    nrm[s] = *hit_n[s];
    if (Dot(nrm[s], d) > 0) nrm[s] = -nrm[s];
    if (!f.sun) continue;
    const double t = hit_t[s];
    const Vec3 x(f.o[0] + t * d[0], f.o[1] + t * d[1], f.o[2] + t * d[2]);
    if (f.sun_r == 0) {
      sd[s] = f.sun_centre_dir;
    } else {
      const Vec3& su = f.sun->to_sun_world;
      const double a = f.sun_r * samples[s].ux, b = f.sun_r * samples[s].uy;
      sd[s] = Normalized(Vec3(su[0] + a * f.t1[0] + b * f.t2[0], su[1] + a * f.t1[1] + b * f.t2[1],
                              su[2] + a * f.t1[2] + b * f.t2[2]));
    }
    xs[s] = Vec3(x[0] + kShadowOffset * nrm[s][0], x[1] + kShadowOffset * nrm[s][1],
                 x[2] + kShadowOffset * nrm[s][2]);
    cs[s] = Dot(nrm[s], sd[s]);
    if (cs[s] > 0) {
      any_sun_ray = true;
      lo = lo.cwiseMin(xs[s]);
      hi = hi.cwiseMax(xs[s]);
      const int prim = cands[hit_c[s]].prim;
      lit_prim = lit_prim == -1 || lit_prim == prim ? prim : -2;
    }
  }
  if (!casters) casters = PixelCasters(f, sc, any_sun_ray, lo, hi, lit_prim);
  const double ambient = scene.light.ambient;
  double sum = 0;
  for (int s = 0; s < nn; ++s) {
    double passive = ambient;
    const double spec = 0;
    if (f.sun && cs[s] > 0 &&
        (casters->empty() || !Shadowed(xs[s], sd[s], -1, *casters, cands[hit_c[s]].prim)))
      passive += f.sun->irradiance * cs[s];
    sum += refl[s] * passive + spec;
  }
  *radiance = sum / nn;
  return true;
}

// The rest of one pixel's work (its planned draws are done): returns its radiance.
double Renderer::Impl::RenderPixel(const Frame& f, const PixelJob& J,
                                   const std::vector<Caster>* casters, Scratch* sc) const {
  const int nn = f.n * f.n;
  if (J.plan.planned && !f.moving) {
    const Lighting& L = scene.light;
    if (J.cands->empty() && scene.background.kind == Background::Kind::kEarth)
      return EarthPixel(f, J, sc->ray.data());
    if (J.plan.face_only && !L.earthshine && !L.narrow_band_filter && !(L.ring_light > 0) &&
        !(prims[(*J.cands)[0].prim].material.specular > 0) &&
        (!f.sun || (casters && casters->empty()))) {
      double v;
      if (FacePixel(f, J, sc->ray.data(), &v)) return v;
    }
    if (J.plan.cover >= 0 && !J.plan.face_only && !L.earthshine && !L.narrow_band_filter &&
        !(L.ring_light > 0) && !(prims[(*J.cands)[J.plan.cover].prim].material.specular > 0) &&
        prims[(*J.cands)[J.plan.cover].prim].material.pattern.kind == Pattern::Kind::kUniform) {
      double v;
      if (CoveredPixel(f, J, sc->ray.data(), casters, sc, &v)) return v;
    }
  }
  Sample* samples = J.samples;
  const std::vector<Candidate>& cands = *J.cands;
  const PixelPlan& plan = J.plan;
  const int x = J.x, y = J.y;
  bool traced = false;
  if (plan.planned) {
    // Camera rays: world, unit.
    double* ray = sc->ray.data();
    CameraRays(f, J, ray);
    for (int k = 0; k < nn; ++k) {
      Sample& smp = samples[k];
      smp.px = x - 0.5 + smp.px;
      smp.py = y - 0.5 + smp.py;
      smp.d = Vec3(ray[k], ray[nn + 2 + k], ray[2 * (nn + 2) + k]);
      smp.o = f.o;
      smp.prim = -1;
      smp.value = 0;
    }
    traced = true;
    if (plan.cover >= 0) {
      for (int k = 0; k < nn && traced; ++k) {
        Sample& smp = samples[k];
        if (plan.face_only) {
          traced = FaceHit(cands[0], plan, smp.d, &smp.hit);
          smp.prim = cands[0].prim;
        } else {
          traced = NearestCovered(cands, plan, smp.o, smp.d, &smp.hit, &smp.prim);
        }
      }
    }
    // (Not what the plan promised, which cannot happen: trace one sample at a time.)
  }
  if (!traced) TracePixel(f, x, y, cands, samples, sc);

  // The background behind the samples that hit nothing, two at a time.
  int* idx = sc->idx.data();
  if (scene.background.kind != Background::Kind::kBlack) {
    int m = 0;
    for (int k = 0; k < nn; ++k)
      if (samples[k].prim < 0) idx[m++] = k;
    if (scene.background.kind == Background::Kind::kEarth && m > 0) {
      const EarthRef ref = MakeEarthRef(samples[idx[0]].d);
      for (int i = 0; i < m; i += 2) {
        Sample& a = samples[idx[i]];
        Sample& b = samples[idx[i + 1 < m ? i + 1 : i]];
        EarthNear2(ref, Load2(a.d, b.d), &a.value, &b.value);
      }
    } else if (scene.background.kind == Background::Kind::kImage) {
      for (int i = 0; i < m; ++i)
        samples[idx[i]].value =
            BackgroundRadiance(samples[idx[i]].d, samples[idx[i]].px, samples[idx[i]].py);
    }
  }

  // The hits: world normal and point, the sun ray.
  int m = 0;
  for (int k = 0; k < nn; ++k) {
    Sample& smp = samples[k];
    if (smp.prim < 0) continue;
    const Vec3& d = smp.d;
    const Vec3& o = smp.o;
    Vec3& nrm = smp.hit.surf.normal;
    nrm = Mul(prims[smp.prim].R, smp.hit.n_local);
    if (Dot(nrm, d) > 0) nrm = -nrm;
    const double t = smp.hit.t;
    smp.x = Vec3(o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]);
    idx[m++] = k;
  }
  bool any_sun_ray = false;
  int lit_prim = -1;  // the primitive all lit samples are on, or -2
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  if (f.sun && m > 0) {
    if (f.sun_r == 0) {
      for (int i = 0; i < m; ++i)
        samples[idx[i]].sd = f.sun_centre_dir;  // what the disc sample reduces to
    } else {
      // normalize(to_sun + (sun_r ux) t1 + (sun_r uy) t2)
      const Vec3& s = f.sun->to_sun_world;
      const F64x2 r_sun = _mm_set1_pd(f.sun_r);
      for (int i = 0; i < m; i += 2) {
        Sample& a = samples[idx[i]];
        Sample& b = samples[idx[i + 1 < m ? i + 1 : i]];
        const F64x2 ca = _mm_mul_pd(r_sun, _mm_set_pd(b.ux, a.ux)),
                    cb = _mm_mul_pd(r_sun, _mm_set_pd(b.uy, a.uy));
        auto comp = [&](int c) {
          return _mm_add_pd(_mm_add_pd(_mm_set1_pd(s[c]), _mm_mul_pd(ca, _mm_set1_pd(f.t1[c]))),
                            _mm_mul_pd(cb, _mm_set1_pd(f.t2[c])));
        };
        Store2(Normalized2(V2{comp(0), comp(1), comp(2)}), &a.sd, &b.sd);
      }
    }
    for (int i = 0; i < m; ++i) {
      Sample& smp = samples[idx[i]];
      const Vec3& nrm = smp.hit.surf.normal;
      smp.xs = Vec3(smp.x[0] + kShadowOffset * nrm[0], smp.x[1] + kShadowOffset * nrm[1],
                    smp.x[2] + kShadowOffset * nrm[2]);
      smp.cs = Dot(nrm, smp.sd);
      if (smp.cs > 0) {
        any_sun_ray = true;
        lo = lo.cwiseMin(smp.xs);
        hi = hi.cwiseMax(smp.xs);
        lit_prim = lit_prim == -1 || lit_prim == smp.prim ? smp.prim : -2;
      }
    }
  }
  if (!casters) casters = PixelCasters(f, sc, any_sun_ray, lo, hi, lit_prim);

  // Shade: the mean of the samples, summed in their order. Lit by sun and ambient only, a matte
  // surface with nothing to cast a shadow on it is Shade's first lines, inline.
  const Lighting& L = scene.light;
  const bool plain_light = !L.earthshine && !L.narrow_band_filter && !(L.ring_light > 0);
  const bool no_casters = casters->empty();
  double sum = 0;
  for (int k = 0; k < nn; ++k) {
    const Sample& smp = samples[k];
    if (smp.prim < 0) {
      sum += smp.value;
      continue;
    }
    const Surface& s = smp.hit.surf;
    if (!plain_light || s.specular > 0 || !no_casters || s.well_prim >= 0) {
      sum += Shade(f, smp, *casters);
      continue;
    }
    double passive = L.ambient;
    const double spec = 0;
    if (f.sun && smp.cs > 0) passive += f.sun->irradiance * smp.cs;
    sum += s.reflectance * passive + spec;
  }
  return sum / nn;
}

// The casters (of f.casters) some sun ray from the box [lo, hi] may hit. The rays start within
// rho of m and run within angle `sun_spread` of to_sun; one that hits a caster's sphere (c, R)
// does so at t <= |c - m| + rho + R, where it is within rho + t * spread of the ray from m
// along to_sun. And a box that all the rays start beyond one face of and leave that face's
// plane cannot be entered (a face lit by the sun does not shadow itself).
void Renderer::Impl::CullCasters(const Frame& f, const Vec3& lo, const Vec3& hi,
                                 std::vector<Caster>* out, int self_box) const {
  out->clear();
  const Vec3 m = 0.5 * (lo + hi), hv = 0.5 * (hi - lo);
  const double rho = hv.norm();
  for (const Caster& c : f.casters) {
    if (c.prim == self_box) continue;  // every sun ray starts on its lit face (see Shadowed)
    const Vec3 v = c.centre - m;
    const double dist2 = v.squaredNorm(), dist = std::sqrt(dist2);
    const double a = v.dot(f.to_sun);
    const double miss = a > 0 ? std::sqrt(std::max(0.0, dist2 - a * a)) : dist;
    const double reach = c.radius + rho + (dist + rho + c.radius) * f.sun_spread;
    if (miss > reach * (1 + 1e-6) + 1e-9) continue;
    const Prim& p = prims[c.prim];
    if (p.kind == Prim::Kind::kBox) {
      bool beyond = false;
      for (int k = 0; k < 3 && !beyond; ++k) {
        const Vec3 nk = p.R.col(k);
        const double centre = Dot(nk, m - p.t), ext = std::abs(nk[0]) * hv[0] +
                                                      std::abs(nk[1]) * hv[1] +
                                                      std::abs(nk[2]) * hv[2];
        const double along = Dot(nk, f.to_sun), spread = f.sun_spread * 1.01 + 1e-12;
        beyond = (centre - ext > p.half[k] + 1e-9 && along > spread) ||
                 (centre + ext < -p.half[k] - 1e-9 && along < -spread);
      }
      if (beyond) continue;
    }
    out->push_back(c);
  }
}

// Traces the samples of pixel (x, y) one after the other (whether a sample hits decides
// whether it draws a sun-disc point, hence the next sample's jitter), from its candidates
// `cands` (unused with motion blur: each sample then has its own camera centre).
void Renderer::Impl::TracePixel(const Frame& f, int x, int y, const std::vector<Candidate>& cands,
                                Sample* samples, Scratch* sc) const {
  const int n = f.n;
  const bool n_pow2 = (n & (n - 1)) == 0;
  const double inv_n = 1.0 / n;
  auto corner = [&](int i, int j) -> const Eigen::Vector3f& {
    return corner_dirs[static_cast<size_t>(j) * (W + 1) + i];
  };
  const Eigen::Vector3f &c00 = corner(x, y), &c10 = corner(x + 1, y), &c01 = corner(x, y + 1),
                        &c11 = corner(x + 1, y + 1);
  Rng rng(PixelSeed(f.view, x, y));
  for (int sy = 0; sy < n; ++sy) {
    for (int sx = 0; sx < n; ++sx) {
      Sample& smp = samples[sy * n + sx];
      const double jx = sx + rng.Uniform();
      const double fx = n_pow2 ? jx * inv_n : jx / n;
      const double jy = sy + rng.Uniform();
      const double fy = n_pow2 ? jy * inv_n : jy / n;
      smp.px = x - 0.5 + fx;
      smp.py = y - 0.5 + fy;
      const Vec3 d_cam = Normalized(Blend(c00, c10, c01, c11, fx, fy).cast<double>());
      const std::vector<Candidate>* cs = &cands;
      if (f.moving) {
        const Pose wfc =
            WorldFromCam(f, scene.sensor.motion_blur * (sy * n + sx + rng.Uniform()) / (n * n));
        smp.d = Mul(wfc.Rotation(), d_cam);
        smp.o = wfc.tvec;
        AllCandidates(f.view, smp.o, &sc->moving_candidates);
        cs = &sc->moving_candidates;
      } else {
        smp.d = Mul(f.Rwc, d_cam);
        smp.o = f.o;
      }
      if (cs->empty() || !Nearest(*cs, smp.o, smp.d, &smp.hit, &smp.prim)) {
        smp.prim = -1;
        smp.value = 0;
        continue;
      }
      if (f.sun) SunDiscPoint(&rng, &smp.ux, &smp.uy);
    }
  }
}

// How an image is rendered (one core; about 0.9 s for a 1024 x 1024 image at 16 rays per
// pixel, bench/render_bench.cc): 16 x 16 pixel tiles keep the primitives their cone of rays
// may meet; 4 x 4 blocks, then pixels, narrow that down (ConeCandidates) and find out which
// pixels see only the background or lie inside one box face; those pixels' random numbers are
// drawn up front and their samples traced and shaded in tight loops (EarthPixel, FacePixel,
// CoveredPixel), the others one sample after another (TracePixel, RenderPixel). Every shortcut
// either does the same floating-point operations as the general path, in the same order, or
// leaves out work whose result is provably not used (a primitive no ray can reach, a shadow
// caster no sun ray can reach): the images are the same to the bit as the straightforward
// per-sample renderer's. The one exception is the earth's longitude and latitude, computed
// within a few ulp of libm's (EarthRef), which moves a radiance by float rounding at most.
cv::Mat Renderer::RenderRadiance(int view) const {
  const Impl& I = *impl_;
  cv::Mat out(I.H, I.W, CV_32F, cv::Scalar(0));
  const Impl::Frame f = I.MakeFrame(view);
  const bool moving = f.moving;
  const Vec3& o = f.o;
  const Mat3& Rwc = f.Rwc;
  std::vector<Candidate> candidates;
  Impl::Scratch scratch;
  scratch.idx.resize(static_cast<size_t>(f.n) * f.n);
  scratch.ray.resize(3 * (static_cast<size_t>(f.n) * f.n + 2));
  // The primitives the cone of rays of tile [tx, x1) x [ty, y1) may meet (from its border
  // corner rays); with motion blur none: each sample casts from its own camera centre
  // (RenderBlock builds those candidates).
  auto tile_candidates = [&](int tx, int ty, int x1, int y1) {
    candidates.clear();
    if (moving) return;
    Vec3 axis = Vec3::Zero();
    std::vector<Vec3> border;
    for (int i = tx; i <= x1; ++i)
      for (int j : {ty, y1})
        border.push_back(I.corner_dirs[static_cast<size_t>(j) * (I.W + 1) + i].cast<double>());
    for (int j = ty; j <= y1; ++j)
      for (int i : {tx, x1})
        border.push_back(I.corner_dirs[static_cast<size_t>(j) * (I.W + 1) + i].cast<double>());
    bool valid = true;
    for (const Vec3& b : border) {
      valid = valid && b.allFinite();
      if (b.allFinite()) axis += b;
    }
    if (!valid) {
      I.AllCandidates(view, o, &candidates);
      return;
    }
    axis = Rwc * axis.normalized();
    double cos_half = 1;
    for (const Vec3& b : border) cos_half = std::min(cos_half, axis.dot(Rwc * b));
    const double half = std::acos(std::clamp(cos_half, -1.0, 1.0)) + 1e-4;
    for (int i : I.view_prims[view]) {
      const Prim& p = I.prims[i];
      const Vec3 v = p.centre - o;
      const double dist = v.norm();
      const double ang =
          dist <= p.radius ? 0 : std::acos(std::clamp(axis.dot(v) / dist, -1.0, 1.0));
      if (dist <= p.radius || ang <= half + std::asin(std::min(1.0, p.radius / dist)))
        candidates.push_back({i, MulT(p.R, o - p.t)});
    }
  };
  for (int ty = 0; ty < I.H; ty += kTile) {
    for (int tx = 0; tx < I.W; tx += kTile) {
      const int x1 = std::min(I.W, tx + kTile), y1 = std::min(I.H, ty + kTile);
      tile_candidates(tx, ty, x1, y1);
      // Nothing to hit and a black sky: the tile stays black.
      if (!moving && candidates.empty() && I.scene.background.kind == Background::Kind::kBlack)
        continue;
      for (int by = ty; by < y1; by += kBlock)
        for (int bx = tx; bx < x1; bx += kBlock)
          I.RenderBlock(f, bx, by, std::min(x1, bx + kBlock), std::min(y1, by + kBlock), candidates,
                        &scratch, &out);
    }
  }
  if (I.scene.sensor.edge_rays_per_pixel > I.scene.sensor.rays_per_pixel)
    I.RefineEdges(f, tile_candidates, candidates, &out);
  return out;
}

cv::Mat EdgePixels(const cv::Mat& radiance) {
  const int H = radiance.rows, W = radiance.cols;
  cv::Mat edge(H, W, CV_8U, cv::Scalar(0));
  auto at = [&](int x, int y) { return static_cast<double>(radiance.ptr<float>(y)[x]); };
  auto inside = [&](int x, int y) { return x >= 0 && y >= 0 && x < W && y < H; };
  // Half the eight neighbours: each direction through the pixel once.
  constexpr int kDirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double c = at(x, y);
      bool on = false;
      for (const auto& d : kDirs) {
        const bool a = inside(x - d[0], y - d[1]), b = inside(x + d[0], y + d[1]);
        const double va = a ? at(x - d[0], y - d[1]) : c, vb = b ? at(x + d[0], y + d[1]) : c;
        if ((a && std::abs(va - c) > kEdgeRadianceJump) ||
            (b && std::abs(vb - c) > kEdgeRadianceJump) ||
            (a && b && std::abs(va - 2 * c + vb) > kEdgeRadianceStep)) {
          on = true;
          break;
        }
      }
      edge.ptr<uint8_t>(y)[x] = on;
    }
  return edge;
}

// Why a second pass and not more rays everywhere: on a 1024 x 1024 view of a 120 px marker,
// 256 rays per pixel take ten times as long as 16 (108 s against 10 s for 40 views), and all
// but about 1.5 % of the pixels (the print's and the silhouettes' edges) gain nothing.
template <typename TileCandidates>
void Renderer::Impl::RefineEdges(const Frame& f, TileCandidates& tile_candidates,
                                 const std::vector<Candidate>& candidates, cv::Mat* out) const {
  // 1. The edge pixels, from the first pass alone (so the result does not depend on the order
  // in which they are refined).
  const cv::Mat edge = EdgePixels(*out);
  // 2. Each rendered again, tile by tile, with the finer grid of jittered samples, through the
  // general per-sample path.
  Frame fine = f;
  fine.n = static_cast<int>(std::lround(std::sqrt(scene.sensor.edge_rays_per_pixel)));
  const int nn = fine.n * fine.n;
  Scratch sc;
  sc.idx.resize(nn);
  sc.ray.resize(3 * (static_cast<size_t>(nn) + 2));
  sc.samples.resize(nn);
  std::vector<Candidate> pixel_cands;
  auto corner = [&](int x, int y) -> Vec3 {
    return Normalized(Mul(f.Rwc, corner_dirs[static_cast<size_t>(y) * (W + 1) + x].cast<double>()));
  };
  for (int ty = 0; ty < H; ty += kTile) {
    for (int tx = 0; tx < W; tx += kTile) {
      const int x1 = std::min(W, tx + kTile), y1 = std::min(H, ty + kTile);
      bool any = false;
      for (int y = ty; y < y1 && !any; ++y)
        for (int x = tx; x < x1 && !any; ++x) any = edge.at<uint8_t>(y, x);
      if (!any) continue;
      tile_candidates(tx, ty, x1, y1);
      for (int y = ty; y < y1; ++y)
        for (int x = tx; x < x1; ++x) {
          if (!edge.at<uint8_t>(y, x)) continue;
          auto finite = [&](int i, int j) {
            return corner_dirs[static_cast<size_t>(j) * (W + 1) + i].allFinite();
          };
          if (!finite(x, y) || !finite(x + 1, y) || !finite(x, y + 1) || !finite(x + 1, y + 1))
            continue;  // as in the first pass: a pixel the lens cannot see stays 0
          PixelJob J;
          J.x = x;
          J.y = y;
          J.valid = true;
          J.samples = sc.samples.data();
          pixel_cands.clear();
          if (f.moving) {
            J.cands = &pixel_cands;  // TracePixel gathers each sample's own
          } else {
            const Vec3 c[4] = {corner(x, y), corner(x + 1, y), corner(x, y + 1),
                               corner(x + 1, y + 1)};
            PixelPlan plan;
            ConeCandidates(fine, c, 4, candidates, &pixel_cands, &plan);
            J.cands = &pixel_cands;
          }
          J.plan = PixelPlan{};  // not planned: every sample traced on its own
          out->ptr<float>(y)[x] = static_cast<float>(RenderPixel(fine, J, nullptr, &sc));
        }
    }
  }
}

namespace {

// The colour (0 red, 1 green, 2 blue) of each pixel of the 2x2 cell of a Bayer pattern, in
// the order (0, 0), (1, 0), (0, 1), (1, 1) as (x, y): the pattern's letters read row by row.
std::array<int, 4> BayerCell(const std::string& pattern) {
  std::array<int, 4> cell{};
  for (int i = 0; i < 4; ++i) cell[i] = pattern[i] == 'R' ? 0 : pattern[i] == 'G' ? 1 : 2;
  return cell;
}

}  // namespace

cv::Mat Renderer::Expose(const cv::Mat& radiance, int view) const {
  return Expose(radiance, view, impl_->scene.sensor);
}

cv::Mat Renderer::Expose(const cv::Mat& radiance, int view, const Sensor& s) const {
  assert(CheckSensor(s).ok());
  Response response;  // linear unless the sensor says otherwise; a table is never read here
  if (s.response.rfind("table:", 0) != 0) Response::Parse(s.response, &response);
  cv::Mat e = radiance.clone();
  if (s.vignetting > 0) {
    const double cx = 0.5 * (e.cols - 1), cy = 0.5 * (e.rows - 1), r2max = cx * cx + cy * cy;
    for (int y = 0; y < e.rows; ++y) {
      float* row = e.ptr<float>(y);
      for (int x = 0; x < e.cols; ++x)
        row[x] *= static_cast<float>(1 - s.vignetting *
                                             ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max);
    }
  }
  if (s.defocus_sigma_px > 0)
    cv::GaussianBlur(e, e, cv::Size(0, 0), s.defocus_sigma_px, 0, cv::BORDER_REFLECT);
  // Per pixel of a 2x2 cell: the electrons a grey pixel's are multiplied by (1 without a
  // colour filter array).
  std::array<double, 4> gain = {1, 1, 1, 1};
  if (!s.bayer.empty()) {
    const std::array<int, 4> cell = BayerCell(s.bayer);
    for (int i = 0; i < 4; ++i) gain[i] = s.channel_gain[cell[i]];
  }
  const double max_dn = s.bits == 16 ? 65535.0 : 255.0;
  const double black = s.black_level, span = s.white_level() - s.black_level;
  // Linear: DN = black + electrons * (span / full_well), clipped to [black, white]. Written
  // with the product first (not s * span) so that the default sensor (black 0, span 2^bits - 1)
  // rounds exactly as round(electrons * (2^bits - 1) / full_well) does, bit for bit: the images
  // the datasets' results were measured on.
  const bool linear = response.kind() == Response::Kind::kLinear;
  const double dn_per_electron = span / s.full_well;
  std::mt19937_64 rng(Mix(impl_->scene.seed ^ Mix(0x5e55000ULL + view)));
  std::normal_distribution<double> gauss(0, 1);
  cv::Mat out(e.rows, e.cols, s.bits == 16 ? CV_16U : CV_8U);
  for (int y = 0; y < e.rows; ++y) {
    const float* row = e.ptr<float>(y);
    for (int x = 0; x < e.cols; ++x) {
      double electrons = std::max(0.0, s.exposure * row[x]);
      if (!s.bayer.empty()) electrons *= gain[(y & 1) * 2 + (x & 1)];
      if (s.shot_noise && electrons > 0) {
        // Exact Poisson below 1000 electrons; beyond, its normal limit (relative error < 1e-3).
        if (electrons < 1000) {
          electrons = std::poisson_distribution<int>(electrons)(rng);
        } else {
          electrons += std::sqrt(electrons) * gauss(rng);
        }
      }
      if (s.read_noise > 0) electrons += s.read_noise * gauss(rng);
      const double signal =
          linear ? std::clamp(electrons * dn_per_electron, 0.0, span)
                 : response.FromLinear(std::clamp(electrons / s.full_well, 0.0, 1.0)) * span;
      const double dn = std::clamp(std::round(black + signal), 0.0, max_dn);
      if (s.bits == 16) {
        out.at<uint16_t>(y, x) = static_cast<uint16_t>(dn);
      } else {
        out.at<uint8_t>(y, x) = static_cast<uint8_t>(dn);
      }
    }
  }
  return out;
}

std::string ViewFileExtension(const Sensor& sensor) {
  return sensor.format == "jpeg" ? ".jpg" : ".png";
}

ImageEncoding ViewImageEncoding(const Sensor& sensor) {
  ImageEncoding encoding;
  if (sensor.format == "jpeg") {
    encoding.jpeg_quality = sensor.jpeg_quality;
    return encoding;
  }
  // The response's one spelling ("sRGB" -> "srgb"); a table, never parsed here (it would
  // read its file), is left for the encoder to refuse.
  Response r;
  encoding.png_response = sensor.response;
  if (sensor.response.rfind("table:", 0) != 0 && Response::Parse(sensor.response, &r))
    encoding.png_response = r.Name();
  return encoding;
}

Status ThroughCodec(const Sensor& sensor, const cv::Mat& exposed, cv::Mat* decoded) {
  if (sensor.format != "jpeg") {
    *decoded = exposed;
    return Status::Ok();
  }
  const std::string name = "view" + ViewFileExtension(sensor);
  std::string bytes;
  if (Status s = EncodeImage(name, exposed, ViewImageEncoding(sensor), &bytes); !s) return s;
  cv::Mat img;
  try {
    const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8U, bytes.data());
    img = cv::imdecode(buf, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception&) {
    img.release();
  }
  if (img.empty())
    return Status::Error(name + ": OpenCV cannot decode the " + std::to_string(bytes.size()) +
                         " bytes its own encoder wrote");
  *decoded = img;
  return Status::Ok();
}

bool Renderer::CameraRay(double u, double v, Vec3* direction) const {
  const Impl& I = *impl_;
  const double gx = u + 0.5, gy = v + 0.5;  // corner-grid coordinates
  if (!(gx >= 0 && gy >= 0 && gx <= I.W && gy <= I.H)) return false;
  const int x = std::min(static_cast<int>(gx), I.W - 1),
            y = std::min(static_cast<int>(gy), I.H - 1);
  const float fx = static_cast<float>(gx - x), fy = static_cast<float>(gy - y);
  auto at = [&](int i, int j) { return I.corner_dirs[static_cast<size_t>(j) * (I.W + 1) + i]; };
  const Eigen::Vector3f d = (1 - fy) * ((1 - fx) * at(x, y) + fx * at(x + 1, y)) +
                            fy * ((1 - fx) * at(x, y + 1) + fx * at(x + 1, y + 1));
  if (!d.allFinite()) return false;
  *direction = d.cast<double>().normalized();
  return true;
}

std::optional<RayHit> Renderer::Cast(int view, const Vec3& origin, const Vec3& direction) const {
  const Vec3 d = direction.normalized();
  LocalHit h;
  int prim;
  if (!impl_->Nearest(impl_->AllCandidates(view, origin), origin, d, &h, &prim))
    return std::nullopt;
  return RayHit{h.t, origin + h.t * d, prim};
}

bool Renderer::InSunShadow(int view, const Vec3& point) const {
  const Sun* sun = impl_->SunOf(view);
  if (!sun) return false;
  // Offset toward the sun so a point on a surface does not shadow itself.
  return impl_->Shadowed(point + kShadowOffset * sun->to_sun_world, sun->to_sun_world, -1,
                         impl_->Casters(view, nullptr));
}

}  // namespace svms

namespace svms {

double RenderMemoryBytes(const Scene& scene, int threads) {
  const double pixels = static_cast<double>(scene.camera.width()) * scene.camera.height();
  // Measured peak resident memory of `svms render`: 51 bytes per pixel above a 60 MB base at
  // 4, 9 and 16 megapixels, the same with 1, 2 and 4 threads (the renderer's per-pixel state,
  // built by Create, dominates: the pixel-corner rays and their unprojection). Counted as 56
  // per pixel, plus 16 per pixel for each view in flight (radiance, edges, exposure, encoding).
  return 56 * pixels + 16 * pixels * std::max(threads, 1) + 100e6;
}

}  // namespace svms
