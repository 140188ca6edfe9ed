// Culling: which primitives the rays of a tile, a block or a pixel may hit, and which shadow
// casters a sun ray from a pixel's hit points may meet. Every test is conservative (it keeps
// whatever might be hit, widened beyond rounding), so culling changes which work is done and
// never a result. A pixel's rays are blends of its four corner rays, so they lie in the cone
// those span; a tile's or a block's rays in the cone of its border's corner rays.
#include <algorithm>
#include <cmath>

#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

namespace {

// The cone (apex `apex`, unit `axis`) that a set of unit rays lies in, widened by 2e-6 rad
// beyond their own spread: cos_m and sin_m of its half angle.
struct Cone {
  Vec3 apex, axis;
  double cos_m = 1, sin_m = 0;
  // True if the sphere (centre, radius) may meet the cone.
  bool MayMeetSphere(const Vec3& centre, double radius) const {
    const Vec3 v = centre - apex;
    const double dist = std::sqrt(Dot(v, v));
    if (dist <= radius) return true;
    const double sin_b = radius / dist, cos_b = std::sqrt(std::max(0.0, 1 - sin_b * sin_b));
    return Dot(axis, v) >= dist * (cos_m * cos_b - sin_m * sin_b) - 1e-12 * dist;
  }
};

// The cone of the unit rays c[0..nc) from `apex`. False if it is not a pixel-sized cone (half
// angle of 60 degrees or more, or NaN).
bool RayCone(const Vec3& apex, const Vec3* c, int nc, Cone* cone) {
  Vec3 axis = Vec3::Zero();
  for (int i = 0; i < nc; ++i) axis += c[i];
  axis = Normalized(axis);
  double cos_t = 1;
  for (int i = 0; i < nc; ++i) cos_t = std::min(cos_t, Dot(axis, c[i]));
  constexpr double kWiden = 2e-6;
  const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
  const double cos_m = cos_t - kWiden * sin_t - kWiden * kWiden,
               sin_m = std::sqrt(std::max(0.0, 1 - cos_m * cos_m));
  cone->apex = apex;
  cone->axis = axis;
  cone->cos_m = cos_m;
  cone->sin_m = sin_m;
  return cos_m > 0.5;
}

// True if a ray of `cone` may hit box `p` (ray origin `lo` in the box's frame). A ray of the
// cone hitting the box does so at t <= T (the far side of its bounding sphere), so the axis ray
// passes through the box grown by T * theta on every side; theta bounds the cone's half angle.
bool BoxMayMeetCone(const Prim& p, const Vec3& lo, const Cone& cone, double theta) {
  const double grow =
      (std::sqrt(Dot(p.centre - cone.apex, p.centre - cone.apex)) + p.radius) * theta * (1 + 1e-6) +
      1e-9;
  const Vec3 la = MulT(p.R, cone.axis);
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
  return tn <= tf;
}

}  // namespace

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
  Cone cone;
  if (!RayCone(f.o, c, nc, &cone)) {  // not a pixel-sized cone (or NaN): keep everything
    *out = tile;
    return;
  }
  // The cone's rays within distance T of the camera are within T * theta of its axis.
  const double theta = 1.5708 * cone.sin_m;  // >= the angle (< 60 degrees)
  for (const Candidate& cand : tile) {
    const Prim& p = prims[cand.prim];
    if (!cone.MayMeetSphere(p.centre, p.radius)) continue;
    if (p.kind == Prim::Kind::kBox) {
      if (BoxMayMeetCone(p, cand.local_origin, cone, theta)) {
        if (plan->cover < 0 && BoxCoversRays(f, c, nc, p, cand.local_origin, plan))
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
    if (p.has_post && p.post_h > 0 && cone.MayMeetSphere(p.post_centre, p.post_radius)) {
      out->push_back(cand);
      continue;
    }
    if (DecalMayMeetRays(p, cand.local_origin, c, nc)) {
      Candidate decal_only = cand;
      decal_only.no_post = true;
      out->push_back(decal_only);
    }
  }
  if (plan->cover >= 0) {
    const Prim& p = prims[(*out)[plan->cover].prim];
    plan->face_only = out->size() == 1 && p.material.pattern.kind == Pattern::Kind::kUniform;
  }
}

// True if all the rays c[0..nc) (world, unit, from f.o; `lo` the origin in the frame of box
// `p`) enter the box through one face (plan->axis, plan->sign) well inside its edges; also
// sets plan's footprint (where they meet the face, world, and their longest distance).
bool Renderer::Impl::BoxCoversRays(const Frame& f, const Vec3* c, int nc, const Prim& p,
                                   const Vec3& lo, PixelPlan* plan) const {
  int* axis = &plan->axis;
  double* sign = &plan->sign;
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
}

// True if a ray of c[0..nc) (world, unit; `lo` their origin in the marker's frame) may hit
// the decal of marker `p`: seen only from its front (camera at local z > 0, rays with local
// z < 0), inside the bounds of where the rays meet its plane, widened by 1e-4 of their length.
bool Renderer::Impl::DecalMayMeetRays(const Prim& p, const Vec3& lo, const Vec3* c, int nc) {
  if (!(lo.z() > 0)) return false;
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
  if (away) return false;  // every ray leaves the decal's plane away from it
  if (!decal) {
    const double e = p.decal_half + 1e-4 * t_max + 1e-9;
    decal = qx1 >= -e && qx0 <= e && qy1 >= -e && qy0 <= e;
  }
  return decal;
}

// The primitives of view `view` that cast shadows. With `sun` given (rays within its disc
// only), a post marker whose decal no sun ray can reach from the front is bounded by its
// post alone; otherwise by its bounding sphere.
std::vector<Renderer::Impl::Caster> Renderer::Impl::Casters(int view, const Sun* sun) const {
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

// The casters one pixel's shadow rays must test: the frame's list, narrowed (into
// sc->pixel_casters) to those that can reach a sun ray from the pixel's lit hit points `lit`.
const std::vector<Renderer::Impl::Caster>* Renderer::Impl::PixelCasters(
    const Frame& f, Scratch* sc, const LitBounds& lit) const {
  if (!(lit.any && f.cull_casters && lit.lo.allFinite() && lit.hi.allFinite())) return &f.casters;
  CullCasters(f, lit.lo, lit.hi, &sc->pixel_casters,
              lit.prim >= 0 && prims[lit.prim].kind == Prim::Kind::kBox ? lit.prim : -1);
  return &sc->pixel_casters;
}

// The primitives the cone of rays of tile [tx, x1) x [ty, y1) may meet (from its border
// corner rays), into *out; with motion blur none: each sample casts from its own camera centre
// (RenderBlock builds those candidates).
void Renderer::Impl::TileCandidates(const Frame& f, int tx, int ty, int x1, int y1,
                                    std::vector<Candidate>* out) const {
  std::vector<Candidate>& candidates = *out;
  const int view = f.view;
  const Vec3& o = f.o;
  const Mat3& Rwc = f.Rwc;
  candidates.clear();
  if (f.moving) return;
  Vec3 axis = Vec3::Zero();
  std::vector<Vec3> border;
  for (int i = tx; i <= x1; ++i)
    for (int j : {ty, y1})
      border.push_back(corner_dirs[static_cast<size_t>(j) * (W + 1) + i].cast<double>());
  for (int j = ty; j <= y1; ++j)
    for (int i : {tx, x1})
      border.push_back(corner_dirs[static_cast<size_t>(j) * (W + 1) + i].cast<double>());
  bool valid = true;
  for (const Vec3& b : border) {
    valid = valid && b.allFinite();
    if (b.allFinite()) axis += b;
  }
  if (!valid) {
    AllCandidates(view, o, &candidates);
    return;
  }
  axis = Rwc * axis.normalized();
  double cos_half = 1;
  for (const Vec3& b : border) cos_half = std::min(cos_half, axis.dot(Rwc * b));
  const double half = std::acos(std::clamp(cos_half, -1.0, 1.0)) + 1e-4;
  for (int i : view_prims[view]) {
    const Prim& p = prims[i];
    const Vec3 v = p.centre - o;
    const double dist = v.norm();
    const double ang = dist <= p.radius ? 0 : std::acos(std::clamp(axis.dot(v) / dist, -1.0, 1.0));
    if (dist <= p.radius || ang <= half + std::asin(std::min(1.0, p.radius / dist)))
      candidates.push_back({i, MulT(p.R, o - p.t)});
  }
}

}  // namespace svms
