// What a ray that hits nothing sees: black, an image behind the scene (scaled to the camera's
// size, looked up by pixel position), or a procedural earth seen from orbit (an
// equirectangular texture, looked up by the ray's world direction). The earth is looked up two
// rays at a time, with longitude and latitude from a vectorised atan2 within a few ulp of
// libm's, and for the rays of one pixel as small differences from the pixel's first ray.
#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

// The radiance behind a ray (world direction `d_world`) through image position (px, py).
double Renderer::Impl::BackgroundRadiance(const Vec3& d_world, double px, double py) const {
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
void Renderer::Impl::EarthRadiance2(const V2& d, double* a, double* b) const {
  F64x2 lon, lat;
  EarthAngles2(d, &lon, &lat);
  EarthLookup2(lon, lat, a, b);
}
void Renderer::Impl::EarthAngles2(const V2& d, F64x2* lon, F64x2* lat) {
  const F64x2 one = _mm_set1_pd(1.0);
  const F64x2 s =
      _mm_min_pd(_mm_max_pd(_mm_div_pd(d.z, _mm_sqrt_pd(Dot2(d, d))), _mm_set1_pd(-1.0)), one);
  *lon = Atan2Pd(d.y, d.x);
  *lat = Atan2Pd(s, _mm_sqrt_pd(_mm_mul_pd(_mm_sub_pd(one, s), _mm_add_pd(one, s))));
}

// EarthRef (render_impl.h) of the ray d0.
Renderer::Impl::EarthRef Renderer::Impl::MakeEarthRef(const Vec3& d0) {
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
// The earth's radiance in the two directions of `d` (unit), rays near r's: through their
// differences from r's angles where both are within reach of the series, else EarthRadiance2.
void Renderer::Impl::EarthNear2(const EarthRef& r, const V2& d, double* a, double* b) const {
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
void Renderer::Impl::EarthLookup2(F64x2 lon, F64x2 lat, double* a, double* b) const {
  const F64x2 half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0);
  const F64x2 u = _mm_sub_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(lon, _mm_set1_pd(0.5 / M_PI)), half),
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

// Bilinear interpolation of `img` (CV_32F) at (u, v) (pixel centres at integers): clamped at
// the edges, or wrapped around in x with `wrap_x`.
double Renderer::Impl::Bilinear(const cv::Mat& img, double u, double v, bool wrap_x) {
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

// The image behind the scene (background.image), grey, linear in [0, 1], resized to the
// camera's size. Fails if the file cannot be read as an image.
Status Renderer::Impl::LoadBackdrop() {
  const cv::Mat img =
      cv::imread(scene.background.image_path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  if (img.empty())
    return Status::Error("background.image: " + scene.background.image_path +
                         ": cannot read as an image");
  cv::Mat f;
  img.convertTo(f, CV_32F, img.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255);
  cv::resize(f, backdrop, cv::Size(W, H), 0, 0, cv::INTER_AREA);
  return Status::Ok();
}

}  // namespace svms
