// The planned pixels' shortcuts. A planned pixel's samples are known before tracing to see
// only the background, or to hit one box face (and perhaps marker decals on it), so which
// random numbers each takes is known (RenderBlock draws them up front) and its samples can be
// traced and shaded in tight loops, two at a time in SIMD lanes: the earth alone (EarthPixel),
// one matte face lit by sun and ambient only (FacePixel), such a face with decals on it
// (CoveredPixel). Each does the floating-point operations of pixel.cc's general path in the
// same order, or leaves out work whose result is not used, so the radiance is the same to the
// bit; FusedPixel says when each applies, and a shortcut that meets a ray it did not plan for
// (which cannot happen) gives up before it has changed anything.
#include <algorithm>
#include <cmath>

#include "svms/sim/printed_pattern.h"
#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

// CoveredPixel's records, per sample (at most kMaxFused samples): which candidate it hit, at
// what distance, the reflectance and normal there; then its sun ray.
struct Renderer::Impl::CoveredSamples {
  struct Decal {
    const Prim* p;
    const Candidate* c;
    Vec3 nrm;  // world normal of the decal (local +z)
  };
  Decal decals[8];
  int n_decals = 0;
  Vec3 box_nrm;  // world outward normal of the covering box's face
  int hit_c[kMaxFused];
  double hit_t[kMaxFused], refl[kMaxFused];
  const Vec3* hit_n[kMaxFused];
  Vec3 nrm[kMaxFused], xs[kMaxFused], sd[kMaxFused];
  double cs[kMaxFused];
};

// Whether one of the shortcuts renders planned pixel J, and then its radiance: the earth
// behind a pixel that hits nothing; a box face (uniform, matte) that covers the pixel alone,
// under sun and ambient light only and with no shadow caster in reach; such a face with marker
// decals on it (no post or well in reach).
bool Renderer::Impl::FusedPixel(const Frame& f, const PixelJob& J,
                                const std::vector<Caster>* casters, Scratch* sc,
                                double* radiance) const {
  if (!(J.plan.planned && !f.moving)) return false;
  const Lighting& L = scene.light;
  if (J.cands->empty() && scene.background.kind == Background::Kind::kEarth) {
    *radiance = EarthPixel(f, J, sc->ray.data());
    return true;
  }
  if (J.plan.face_only && !L.earthshine && !L.narrow_band_filter && !(L.ring_light > 0) &&
      !(prims[(*J.cands)[0].prim].material.specular > 0) &&
      (!f.sun || (casters && casters->empty()))) {
    if (FacePixel(f, J, sc->ray.data(), radiance)) return true;
  }
  if (J.plan.cover >= 0 && !J.plan.face_only && !L.earthshine && !L.narrow_band_filter &&
      !(L.ring_light > 0) && !(prims[(*J.cands)[J.plan.cover].prim].material.specular > 0) &&
      prims[(*J.cands)[J.plan.cover].prim].material.pattern.kind == Pattern::Kind::kUniform) {
    if (CoveredPixel(f, J, sc->ray.data(), casters, sc, radiance)) return true;
  }
  return false;
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
  const int nn = f.n * f.n;
  if (nn > kMaxFused) return false;
  CoveredSamples rec;
  if (!CoveredDecals(J, &rec)) return false;
  CameraRays(f, J, ray);
  if (!CoveredHits(f, J, ray, &rec)) return false;
  const LitBounds lit = CoveredSunRays(f, J, ray, &rec);
  if (!casters) casters = PixelCasters(f, sc, lit);
  const std::vector<Candidate>& cands = *J.cands;
  const double ambient = scene.light.ambient;
  double sum = 0;
  for (int s = 0; s < nn; ++s) {
    double passive = ambient;
    const double spec = 0;
    if (f.sun && rec.cs[s] > 0 &&
        (casters->empty() ||
         !Shadowed(rec.xs[s], rec.sd[s], -1, *casters, cands[rec.hit_c[s]].prim)))
      passive += f.sun->irradiance * rec.cs[s];
    sum += rec.refl[s] * passive + spec;
  }
  *radiance = sum / nn;
  return true;
}

// The candidates of covered pixel J other than its box, into rec->decals: false unless each
// is a marker whose decal alone is in reach (no post), and there are at most 8.
bool Renderer::Impl::CoveredDecals(const PixelJob& J, CoveredSamples* rec) const {
  const std::vector<Candidate>& cands = *J.cands;
  rec->n_decals = 0;
  for (size_t i = 0; i < cands.size(); ++i) {
    if (static_cast<int>(i) == J.plan.cover) continue;
    const Prim& p = prims[cands[i].prim];
    if (p.kind != Prim::Kind::kMarker || !(cands[i].no_post || !(p.has_post && p.post_h > 0)) ||
        rec->n_decals == 8)
      return false;
    rec->decals[rec->n_decals++] = {&p, &cands[i], Mul(p.R, Vec3(0, 0, 1))};
  }
  return true;
}

// What each camera ray of covered pixel J (`ray`, as CameraRays leaves it) hits first: the box
// face (FaceHit's arithmetic) or a decal in front of it (Nearest's bounding-sphere rejection,
// then IntersectMarker's decal); into rec's hit_c, hit_t, refl and hit_n. False if a ray
// misses the face or enters a well.
bool Renderer::Impl::CoveredHits(const Frame& f, const PixelJob& J, const double* ray,
                                 CoveredSamples* rec) const {
  const int nn = f.n * f.n, stride = nn + 2;
  const std::vector<Candidate>& cands = *J.cands;
  const PixelPlan& plan = J.plan;
  const Candidate& bc = cands[plan.cover];
  const Prim& box = prims[bc.prim];
  const int k = plan.axis, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  const double sign = plan.sign;
  Vec3 n_local = Vec3::Zero();
  n_local[k] = sign;
  rec->box_nrm = Mul(box.R, n_local);
  const double num =
      sign < 0 ? -box.half[k] - bc.local_origin[k] : box.half[k] - bc.local_origin[k];
  const double *rx = ray, *ry = ray + stride, *rz = ray + 2 * stride;
  int* hit_c = rec->hit_c;
  double *hit_t = rec->hit_t, *refl = rec->refl;
  const Vec3** hit_n = rec->hit_n;
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
          hit_n[s] = &rec->box_nrm;
        }
        continue;
      }
      const CoveredSamples::Decal& dc = rec->decals[decal_i++];
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
  return true;
}

// The sun rays of covered pixel J's samples (their hits in rec): normals facing the rays,
// directions (a point of the sun's disc each), where they start (off the surface) and their
// incidence, into rec's nrm, sd, xs and cs; the bounds of the lit ones.
Renderer::Impl::LitBounds Renderer::Impl::CoveredSunRays(const Frame& f, const PixelJob& J,
                                                         const double* ray,
                                                         CoveredSamples* rec) const {
  const int nn = f.n * f.n, stride = nn + 2;
  const std::vector<Candidate>& cands = *J.cands;
  const Sample* samples = J.samples;
  const double *rx = ray, *ry = ray + stride, *rz = ray + 2 * stride;
  Vec3 *nrm = rec->nrm, *xs = rec->xs, *sd = rec->sd;
  double* cs = rec->cs;
  LitBounds lit;
  for (int s = 0; s < nn; ++s) {
    const Vec3 d(rx[s], ry[s], rz[s]);
    nrm[s] = *rec->hit_n[s];
    if (Dot(nrm[s], d) > 0) nrm[s] = -nrm[s];
    if (!f.sun) continue;
    const double t = rec->hit_t[s];
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
    if (cs[s] > 0) lit.Add(xs[s], cands[rec->hit_c[s]].prim);
  }
  return lit;
}

}  // namespace svms
