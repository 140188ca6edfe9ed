// Rays against the scene's primitives: the nearest hit of a camera ray among the candidates
// that culling left (cull.cc), and whether a sun ray is blocked. Each primitive is intersected
// in its local frame: a box by its slabs, a rectangle and a marker's decal by their planes, a
// sphere by its quadratic, a marker's post by its cylinder and top disc and a well by its bore
// and white-bottomed floor. A marker's decal claims hits on a surface coplanar with it (its
// sort key is kCoplanarWin nearer), so that a marker printed on a box face shows.
#include <algorithm>
#include <cmath>
#include <optional>

#include "svms/sim/printed_pattern.h"
#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

namespace {

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

}  // namespace

// Intersects prim `p` with a local-frame ray; false if missed.
bool Renderer::Impl::Intersect(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
                               bool no_post) const {
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

// The nearest hit of a local-frame ray on marker `p`: its post's side and top (unless
// `no_post`), its decal (from the front only), or inside its well the dark wall or the
// white-bottomed floor. A hit on the decal or in the well sorts kCoplanarWin before the decal's
// plane, so that it wins over the surface the marker lies on.
bool Renderer::Impl::IntersectMarker(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
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
          white = RingWhite(q.x(), q.y(), m.inner->size, m.inner->cell_size, p.inner_word, &inside);
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

// The hit of a ray (world, unit `d`, from the camera) on the face of box candidate `c` that
// `plan` says it enters through: what Intersect gives, with one division. False if the ray
// is not inside that face after all.
bool Renderer::Impl::FaceHit(const Candidate& c, const PixelPlan& plan, const Vec3& d,
                             LocalHit* h) const {
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

// Nearest hit over `candidates` for a world ray from `o` (whose local images the candidates
// carry) along unit `d`.
bool Renderer::Impl::Nearest(const std::vector<Candidate>& candidates, const Vec3& o, const Vec3& d,
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
bool Renderer::Impl::NearestCovered(const std::vector<Candidate>& candidates, const PixelPlan& plan,
                                    const Vec3& o, const Vec3& d, LocalHit* best,
                                    int* best_prim) const {
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

// The candidates of every primitive of view `view` for rays from `o` (world).
void Renderer::Impl::AllCandidates(int view, const Vec3& o, std::vector<Candidate>* out) const {
  out->clear();
  for (int i : view_prims[view]) out->push_back({i, MulT(prims[i].R, o - prims[i].t)});
}
std::vector<Renderer::Impl::Candidate> Renderer::Impl::AllCandidates(int view,
                                                                     const Vec3& o) const {
  std::vector<Candidate> out;
  AllCandidates(view, o, &out);
  return out;
}

// True if `s` (unit, world) from world point `x` is blocked by one of `casters`. `self`: the
// primitive x is on; a box does not block a sun ray leaving its own lit face (it starts
// outside, beyond that face, and moves away from its plane: what Intersect finds too).
bool Renderer::Impl::Shadowed(const Vec3& x, const Vec3& s, int well_prim,
                              const std::vector<Caster>& casters, int self) const {
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
