// The pixels of a block, sample by sample: each pixel's random numbers (jitter, motion-blur
// time, a point of the sun's disc) in one fixed order, its samples traced (trace.cc), the
// background behind those that hit nothing (background.cc), and the rest shaded by sun (with
// shadows), ambient light, earthshine, the ring light and specular glare. The planned pixels'
// shortcuts (fused_pixel.cc) give the same bits as this general path.
#include <algorithm>
#include <cmath>

#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

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

// The rest of one pixel's work (its planned draws are done): returns its radiance.
double Renderer::Impl::RenderPixel(const Frame& f, const PixelJob& J,
                                   const std::vector<Caster>* casters, Scratch* sc) const {
  double v;
  if (FusedPixel(f, J, casters, sc, &v)) return v;
  const int nn = f.n * f.n;
  TraceSamples(f, J, sc);
  int* idx = sc->idx.data();
  BackgroundSamples(nn, J.samples, idx);
  const int m = SurfacePoints(nn, J.samples, idx);
  const LitBounds lit = SunRays(f, J.samples, idx, m);
  if (!casters) casters = PixelCasters(f, sc, lit);
  return ShadeSamples(f, J.samples, nn, *casters);
}

// Traces the samples of pixel J: a planned pixel's camera rays two at a time and, with a
// covering box, their hits; otherwise (or if a ray is not what the plan promised, which cannot
// happen) one sample after another (TracePixel). Leaves each sample's ray, image position and
// hit (prim -1 for none).
void Renderer::Impl::TraceSamples(const Frame& f, const PixelJob& J, Scratch* sc) const {
  const int nn = f.n * f.n;
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
}

// The background radiance behind the samples of samples[0..nn) that hit nothing, two at a time
// (idx: room for nn indices).
void Renderer::Impl::BackgroundSamples(int nn, Sample* samples, int* idx) const {
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
}

// The world normal (facing the ray) and the point of every sample of samples[0..nn) that hit
// something; their indices into idx[0..m), m returned.
int Renderer::Impl::SurfacePoints(int nn, Sample* samples, int* idx) const {
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
  return m;
}

// The sun rays of the samples idx[0..m) (that hit something): their directions (a point of the
// sun's disc each), where they start (off the surface) and their incidence; the bounds of the
// lit ones. Two samples at a time.
Renderer::Impl::LitBounds Renderer::Impl::SunRays(const Frame& f, Sample* samples, const int* idx,
                                                  int m) const {
  LitBounds lit;
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
      if (smp.cs > 0) lit.Add(smp.xs, smp.prim);
    }
  }
  return lit;
}

// The mean radiance of samples[0..nn), summed in their order. Lit by sun and ambient only, a
// matte surface with nothing to cast a shadow on it is Shade's first lines, inline.
double Renderer::Impl::ShadeSamples(const Frame& f, const Sample* samples, int nn,
                                    const std::vector<Caster>& casters) const {
  const Lighting& L = scene.light;
  const bool plain_light = !L.earthshine && !L.narrow_band_filter && !(L.ring_light > 0);
  const bool no_casters = casters.empty();
  double sum = 0;
  for (int k = 0; k < nn; ++k) {
    const Sample& smp = samples[k];
    if (smp.prim < 0) {
      sum += smp.value;
      continue;
    }
    const Surface& s = smp.hit.surf;
    if (!plain_light || s.specular > 0 || !no_casters || s.well_prim >= 0) {
      sum += Shade(f, smp, casters);
      continue;
    }
    double passive = L.ambient;
    const double spec = 0;
    if (f.sun && smp.cs > 0) passive += f.sun->irradiance * smp.cs;
    sum += s.reflectance * passive + spec;
  }
  return sum / nn;
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

// Radiance toward the camera of a traced sample that hit a surface, lit by the frame's sun
// unless one of `casters` blocks it.
double Renderer::Impl::Shade(const Frame& f, const Sample& smp,
                             const std::vector<Caster>& casters) const {
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
Pose Renderer::Impl::WorldFromCam(const Frame& f, double tau) const {
  if (tau <= 0 || !f.two_views) return f.cam_a;
  const double t = f.forward ? tau : -tau;
  return Pose::FromRotation(f.q_a.slerp(t, f.q_b).toRotationMatrix(),
                            (1 - t) * f.cam_a.tvec + t * f.cam_b.tvec);
}

}  // namespace svms
