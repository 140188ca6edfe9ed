#include "svms/render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/svms44.h"

namespace svms {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kEps = 1e-9;            // minimum ray distance, metres
constexpr double kCoplanarWin = 1e-7;    // a marker wins over a coplanar surface by this much
constexpr double kShadowOffset = 1e-6;   // shadow rays start this far off the surface
constexpr int kTile = 16;                // pixels per culling tile side

uint64_t Mix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A small deterministic generator for per-pixel jitter: seeded by hashing the pixel, then
// xorshift64* steps (cheap: the sampler draws several numbers per ray).
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(Mix(seed) | 1) {}
  double Uniform() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return ((s * 0x2545f4914f6cdd1dULL) >> 11) * 0x1.0p-53;
  }
};

// What a surface point looks like.
struct Surface {
  double reflectance = 0;
  bool retro = false;
  double retro_gain = 0;
  double specular = 0, shininess = 1;
  Vec3 normal;            // world, facing the incoming ray
  int well_prim = -1;     // inside the well of this marker primitive (its walls may shade)
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
};

// Local-frame hit.
struct LocalHit {
  double t = 0;        // ray parameter of the hit
  double sort = 0;     // what hits are ordered by (a marker claims coplanar hits)
  Vec3 n_local;        // outward normal, local frame
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
      const double fu = u - p.period * std::floor(u / p.period), fv = v - p.period * std::floor(v / p.period);
      return (fu < p.line || fv < p.line) ? p.low : p.high;
    }
    case Pattern::Kind::kText: {
      // Lines of blocky 5 x 7 glyphs in cells of `period` (wide) x 1.6 period (tall).
      const double gw = p.period, gh = 1.6 * p.period;
      const int64_t gx = static_cast<int64_t>(std::floor(u / gw)), gy = static_cast<int64_t>(std::floor(v / gh));
      const uint64_t g = Mix(p.seed ^ Mix(static_cast<uint64_t>(gx) * 0x9e37ULL ^ Mix(static_cast<uint64_t>(gy))));
      if ((g & 7) == 0) return p.high;  // a space
      const int px = static_cast<int>(std::floor((u - gx * gw) / gw * 6));  // 5 columns + gap
      const int py = static_cast<int>(std::floor((v - gy * gh) / gh * 9));  // 7 rows + gaps
      if (px >= 5 || py < 1 || py > 7) return p.high;
      return ((Mix(g + py) >> px) & 1) ? p.low : p.high;
    }
    case Pattern::Kind::kNoise: {
      const uint64_t h = Mix(p.seed ^ Mix(static_cast<uint64_t>(cell(u)) * 0x51ULL ^ Mix(static_cast<uint64_t>(cell(v)))));
      return p.low + (p.high - p.low) * ((h >> 11) * 0x1.0p-53);
    }
  }
  return m.reflectance;
}

bool InsideSquare(double x, double y, double half) { return std::abs(x) <= half && std::abs(y) <= half; }

// Bit index of the ring cell containing (x, y) (inside the ring), for cell size b.
int CellBit(double x, double y, double b) {
  const int col = std::clamp(static_cast<int>(std::floor((x + 6 * b) / b)), 0, 11);
  const int row = std::clamp(static_cast<int>(std::floor((6 * b - y) / b)), 0, 11);
  if (row == 0 && col <= 10) return col;
  if (col == 11 && row <= 10) return 11 + row;
  if (row == 11 && col >= 1) return 22 + (11 - col);
  return 33 + (11 - row);  // col == 0, row >= 1
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

// A primitive that a tile's rays may hit, with the ray origin in its local frame.
struct Candidate {
  int prim;
  Vec3 local_origin;
};

struct Renderer::Impl {
  Scene scene;
  int W = 0, H = 0;
  std::vector<Eigen::Vector3f> corner_dirs;  // (W+1) x (H+1), camera frame, unit; NaN if invalid
  std::vector<Prim> prims;                   // static prims, then occluders
  std::vector<std::vector<int>> view_prims;  // per view: indices into prims
  cv::Mat earth;                             // equirectangular background texture (CV_32F)
  cv::Mat backdrop;                          // background image at the camera's size (CV_32F)

  const Sun* SunOf(int view) const {
    if (scene.views[view].sun) return &*scene.views[view].sun;
    return scene.light.sun ? &*scene.light.sun : nullptr;
  }

  // Intersects prim `p` with a local-frame ray; false if missed.
  bool Intersect(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h) const {
    switch (p.kind) {
      case Prim::Kind::kBox: {
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
        return IntersectMarker(p, o, d, h);
    }
    return false;
  }

  bool IntersectMarker(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h) const {
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
    if (p.has_post && p.post_h > 0) {
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
          if (m.inner && InsideSquare(q.x(), q.y(), 6 * m.inner->cell_size)) {
            white = RingWhite(q.x(), q.y(), m.inner->size, m.inner->cell_size, p.inner_word, &inside);
          } else {
            white = RingWhite(q.x(), q.y(), m.size, m.cell_size, p.word, &inside);
          }
          if (inside) set(t0, t0 - kCoplanarWin, Vec3(0, 0, 1), white ? sm.white : sm.black, white, -1);
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
      const double along = oc.dot(d);
      if (along < -p.radius) continue;
      if ((oc - along * d).squaredNorm() > p.radius * p.radius) continue;
      const Vec3 ld = p.R.transpose() * d;
      LocalHit h;
      if (Intersect(p, c.local_origin, ld, &h) && h.sort < best->sort) {
        *best = h;
        *best_prim = c.prim;
      }
    }
    return *best_prim >= 0;
  }

  std::vector<Candidate> AllCandidates(int view, const Vec3& o) const {
    std::vector<Candidate> out;
    for (int i : view_prims[view]) out.push_back({i, prims[i].R.transpose() * (o - prims[i].t)});
    return out;
  }

  // True if `s` (unit, world) from world point `x` is blocked.
  bool Shadowed(int view, const Vec3& x, const Vec3& s, int well_prim) const {
    if (well_prim >= 0) {
      // Leaving the well: through its opening, or blocked by the body around it.
      const Prim& p = prims[well_prim];
      const Vec3 lo = p.R.transpose() * (x - p.t), ld = p.R.transpose() * s;
      if (ld.z() <= 0) return true;
      const Vec3 q = lo + (-lo.z() / ld.z()) * ld;
      if (q.x() * q.x() + q.y() * q.y() > p.post_r * p.post_r) return true;
    }
    for (int i : view_prims[view]) {
      const Prim& p = prims[i];
      if (!p.casts_shadow) continue;
      const Vec3 oc = p.centre - x;
      const double along = oc.dot(s);
      if (along < -p.radius) continue;
      if ((oc - along * s).squaredNorm() > p.radius * p.radius) continue;
      const Vec3 lo = p.R.transpose() * (x - p.t), ld = p.R.transpose() * s;
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
        const double lon = std::atan2(d_world.y(), d_world.x());
        const double lat = std::asin(std::clamp(d_world.z() / d_world.norm(), -1.0, 1.0));
        const double u = (lon / (2 * M_PI) + 0.5) * earth.cols - 0.5;
        const double v = (0.5 - lat / M_PI) * earth.rows - 0.5;
        return scene.background.brightness * Bilinear(earth, u, v, true);
      }
      case Background::Kind::kImage:
        return scene.background.brightness * Bilinear(backdrop, px, py, false);
    }
    return 0;
  }

  static double Bilinear(const cv::Mat& img, double u, double v, bool wrap_x) {
    const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
    const double fx = u - x0, fy = v - y0;
    auto at = [&](int y, int x) {
      y = std::clamp(y, 0, img.rows - 1);
      x = wrap_x ? ((x % img.cols) + img.cols) % img.cols : std::clamp(x, 0, img.cols - 1);
      return static_cast<double>(img.at<float>(y, x));
    };
    return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
           fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
  }

  // Radiance toward the camera at a hit (world point x, unit ray d from camera centre c).
  double Shade(int view, const Surface& s, const Vec3& x, const Vec3& d, const Vec3& c,
               const Vec3* sun_dir) const {
    const Lighting& L = scene.light;
    const Vec3& n = s.normal;
    double passive = L.ambient;  // irradiance from everything but the ring light
    double spec = 0;
    const Sun* sun = SunOf(view);
    if (sun && sun_dir) {
      const double cs = n.dot(*sun_dir);
      if (cs > 0 && !Shadowed(view, x + kShadowOffset * n, *sun_dir, s.well_prim)) {
        passive += sun->irradiance * cs;
        if (s.specular > 0) {
          const Vec3 hv = (*sun_dir - d).normalized();
          spec += s.specular * sun->irradiance * std::pow(std::max(0.0, n.dot(hv)), s.shininess);
        }
      }
    }
    if (L.earthshine) passive += L.earthshine->irradiance * std::max(0.0, n.dot(L.earthshine->to_sun_world));
    double radiance = s.reflectance * passive + spec;
    if (L.narrow_band_filter) radiance *= L.filter_transmission;
    if (L.ring_light > 0) {
      const Vec3 to_cam = c - x;
      const double r2 = to_cam.squaredNorm();
      const double cr = std::max(0.0, n.dot(to_cam) / std::sqrt(r2));
      const double gain = s.retro ? s.retro_gain : 1.0;
      radiance += s.reflectance * gain * L.ring_light * cr / r2;
      if (s.specular > 0) radiance += s.specular * L.ring_light / r2 * std::pow(cr, s.shininess);
    }
    return radiance;
  }

  // Camera pose of view `view` at fraction `tau` of the way to the next view (motion blur).
  Pose WorldFromCam(int view, double tau) const {
    const Pose a = scene.views[view].cam_from_world.Inverse();
    if (tau <= 0 || scene.views.size() < 2) return a;
    const int next = view + 1 < static_cast<int>(scene.views.size()) ? view + 1 : view - 1;
    const double f = view + 1 < static_cast<int>(scene.views.size()) ? tau : -tau;
    const Pose b = scene.views[next].cam_from_world.Inverse();
    const Eigen::Quaterniond qa(a.Rotation()), qb(b.Rotation());
    return Pose::FromRotation(qa.slerp(f, qb).toRotationMatrix(), (1 - f) * a.tvec + f * b.tvec);
  }

  Status Build();
  void BuildEarth();
  double RenderPixel(int view, int x, int y, const Mat3& Rwc, const Vec3& cam_centre,
                     const std::vector<Candidate>& candidates) const;
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
      mp.word = Svms44::Codeword(sm.model.id);
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
      p.radius = (o.shape == Occluder::Shape::kBar ? p.half.norm() : o.size.x()) * (1 + 1e-9) + 1e-9;
      idx.push_back(static_cast<int>(prims.size()));
      prims.push_back(p);
    }
    return idx;
  };
  const std::vector<int> shared = add_occluders(scene.occluders);
  view_prims.resize(scene.views.size());
  for (size_t v = 0; v < scene.views.size(); ++v) {
    for (size_t i = 0; i < n_static; ++i) view_prims[v].push_back(static_cast<int>(i));
    const std::vector<int> occ = scene.views[v].occluders ? add_occluders(*scene.views[v].occluders) : shared;
    view_prims[v].insert(view_prims[v].end(), occ.begin(), occ.end());
  }
  // Marker pointers refer into scene.objects, which no longer changes.
  if (scene.background.kind == Background::Kind::kEarth) BuildEarth();
  if (scene.background.kind == Background::Kind::kImage) {
    const cv::Mat img = cv::imread(scene.background.image_path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
    if (img.empty()) return Status::Error("background.image: " + scene.background.image_path + ": cannot read as an image");
    cv::Mat f;
    img.convertTo(f, CV_32F, img.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255);
    cv::resize(f, backdrop, cv::Size(W, H), 0, 0, cv::INTER_AREA);
  }
  return Status::Ok();
}

// A procedural earth seen from orbit: fractal value noise over the sphere, thresholded into
// dark sea and bright cloud, grey. Deterministic from the scene seed.
void Renderer::Impl::BuildEarth() {
  const int w = 2048, h = 1024;
  earth.create(h, w, CV_32F);
  const uint64_t seed = Mix(scene.seed ^ 0xea57ULL);
  auto lattice = [&](int64_t x, int64_t y, int64_t z) {
    return (Mix(seed ^ Mix(x * 73856093LL ^ Mix(y * 19349663LL ^ Mix(z * 83492791LL)))) >> 11) * 0x1.0p-53;
  };
  auto smooth = [](double t) { return t * t * (3 - 2 * t); };
  auto noise = [&](const Vec3& p) {
    const Vec3 f(std::floor(p.x()), std::floor(p.y()), std::floor(p.z()));
    const Vec3 r = p - f;
    const int64_t x = static_cast<int64_t>(f.x()), y = static_cast<int64_t>(f.y()), z = static_cast<int64_t>(f.z());
    double v = 0;
    for (int k = 0; k < 8; ++k) {
      const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
      const double wgt = (dx ? smooth(r.x()) : 1 - smooth(r.x())) * (dy ? smooth(r.y()) : 1 - smooth(r.y())) *
                         (dz ? smooth(r.z()) : 1 - smooth(r.z()));
      v += wgt * lattice(x + dx, y + dy, z + dz);
    }
    return v;
  };
  for (int j = 0; j < h; ++j) {
    const double lat = M_PI * (0.5 - (j + 0.5) / h);
    for (int i = 0; i < w; ++i) {
      const double lon = 2 * M_PI * ((i + 0.5) / w - 0.5);
      const Vec3 p(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
      double v = 0, amp = 0.5, freq = 3;
      for (int o = 0; o < 6; ++o, amp *= 0.5, freq *= 2.1) v += amp * noise(p * freq);
      const double cloud = std::clamp((v - 0.45) * 4, 0.0, 1.0);
      earth.at<float>(j, i) = static_cast<float>(0.12 + 0.08 * v + 0.8 * cloud);
    }
  }
}

double Renderer::Impl::RenderPixel(int view, int x, int y, const Mat3& Rwc_static,
                                   const Vec3& cam_centre,
                                   const std::vector<Candidate>& candidates) const {
  const Eigen::Vector3f& c00 = corner_dirs[static_cast<size_t>(y) * (W + 1) + x];
  const Eigen::Vector3f& c10 = corner_dirs[static_cast<size_t>(y) * (W + 1) + x + 1];
  const Eigen::Vector3f& c01 = corner_dirs[static_cast<size_t>(y + 1) * (W + 1) + x];
  const Eigen::Vector3f& c11 = corner_dirs[static_cast<size_t>(y + 1) * (W + 1) + x + 1];
  if (!(c00.allFinite() && c10.allFinite() && c01.allFinite() && c11.allFinite())) return 0;
  const int n = static_cast<int>(std::lround(std::sqrt(scene.sensor.rays_per_pixel)));
  Rng rng(scene.seed ^ Mix((static_cast<uint64_t>(view) << 40) ^ (static_cast<uint64_t>(y) << 20) ^ x));
  const Sun* sun = SunOf(view);
  Vec3 t1, t2;
  if (sun) {
    t1 = sun->to_sun_world.unitOrthogonal();
    t2 = sun->to_sun_world.cross(t1);
  }
  const double sun_r = sun ? 0.5 * sun->angular_diameter_deg * M_PI / 180 : 0;
  const bool moving = scene.sensor.motion_blur > 0;
  double sum = 0;
  for (int sy = 0; sy < n; ++sy) {
    for (int sx = 0; sx < n; ++sx) {
      const double fx = (sx + rng.Uniform()) / n, fy = (sy + rng.Uniform()) / n;
      const Eigen::Vector3f df = (1 - fy) * ((1 - fx) * c00 + fx * c10) + fy * ((1 - fx) * c01 + fx * c11);
      const Vec3 d_cam = df.cast<double>().normalized();
      Vec3 d, o = cam_centre;
      std::vector<Candidate> moving_candidates;
      if (moving) {
        const Pose wfc = WorldFromCam(view, scene.sensor.motion_blur * (sy * n + sx + rng.Uniform()) / (n * n));
        d = wfc.Rotation() * d_cam;
        o = wfc.tvec;
        moving_candidates = AllCandidates(view, o);
      } else {
        d = Rwc_static * d_cam;
      }
      LocalHit hit;
      int prim;
      if (!Nearest(moving ? moving_candidates : candidates, o, d, &hit, &prim)) {
        sum += BackgroundRadiance(d, x - 0.5 + fx, y - 0.5 + fy);
        continue;
      }
      const Prim& p = prims[prim];
      Surface s = hit.surf;
      s.normal = p.R * hit.n_local;
      if (s.normal.dot(d) > 0) s.normal = -s.normal;
      const Vec3 xw = o + hit.t * d;
      Vec3 sd;
      if (sun) {
        // A uniform point of the sun's disc (rejection sampling: no trigonometry).
        double ux, uy;
        do {
          ux = 2 * rng.Uniform() - 1;
          uy = 2 * rng.Uniform() - 1;
        } while (ux * ux + uy * uy > 1);
        sd = (sun->to_sun_world + sun_r * ux * t1 + sun_r * uy * t2).normalized();
      }
      sum += Shade(view, s, xw, d, o, sun ? &sd : nullptr);
    }
  }
  return sum / (n * n);
}

cv::Mat Renderer::RenderRadiance(int view) const {
  const Impl& I = *impl_;
  cv::Mat out(I.H, I.W, CV_32F, cv::Scalar(0));
  const Pose world_from_cam = I.scene.views[view].cam_from_world.Inverse();
  const bool moving = I.scene.sensor.motion_blur > 0;
  const Vec3 o = world_from_cam.tvec;
  const Mat3 Rwc = world_from_cam.Rotation();
  std::vector<Candidate> candidates;
  for (int ty = 0; ty < I.H; ty += kTile) {
    for (int tx = 0; tx < I.W; tx += kTile) {
      const int x1 = std::min(I.W, tx + kTile), y1 = std::min(I.H, ty + kTile);
      // The tile's cone of rays (from its border corner rays) culls the primitives.
      candidates.clear();
      if (moving) {
        // Each sample casts from its own camera centre (RenderPixel builds those candidates).
      } else {
        Vec3 axis = Vec3::Zero();
        std::vector<Vec3> border;
        for (int i = tx; i <= x1; ++i)
          for (int j : {ty, y1}) border.push_back(I.corner_dirs[static_cast<size_t>(j) * (I.W + 1) + i].cast<double>());
        for (int j = ty; j <= y1; ++j)
          for (int i : {tx, x1}) border.push_back(I.corner_dirs[static_cast<size_t>(j) * (I.W + 1) + i].cast<double>());
        bool valid = true;
        for (const Vec3& b : border) {
          valid = valid && b.allFinite();
          if (b.allFinite()) axis += b;
        }
        if (!valid) {
          candidates = I.AllCandidates(view, o);
        } else {
          axis = Rwc * axis.normalized();
          double cos_half = 1;
          for (const Vec3& b : border) cos_half = std::min(cos_half, axis.dot(Rwc * b));
          const double half = std::acos(std::clamp(cos_half, -1.0, 1.0)) + 1e-4;
          for (int i : I.view_prims[view]) {
            const Prim& p = I.prims[i];
            const Vec3 v = p.centre - o;
            const double dist = v.norm();
            const double ang = dist <= p.radius ? 0 : std::acos(std::clamp(axis.dot(v) / dist, -1.0, 1.0));
            if (dist <= p.radius || ang <= half + std::asin(std::min(1.0, p.radius / dist)))
              candidates.push_back({i, p.R.transpose() * (o - p.t)});
          }
        }
      }
      // Nothing to hit and a black sky: the tile stays black.
      if (!moving && candidates.empty() && I.scene.background.kind == Background::Kind::kBlack) continue;
      for (int y = ty; y < y1; ++y) {
        float* row = out.ptr<float>(y);
        for (int x = tx; x < x1; ++x) row[x] = static_cast<float>(I.RenderPixel(view, x, y, Rwc, o, candidates));
      }
    }
  }
  return out;
}

cv::Mat Renderer::Expose(const cv::Mat& radiance, int view) const {
  const Sensor& s = impl_->scene.sensor;
  cv::Mat e = radiance.clone();
  if (s.vignetting > 0) {
    const double cx = 0.5 * (e.cols - 1), cy = 0.5 * (e.rows - 1), r2max = cx * cx + cy * cy;
    for (int y = 0; y < e.rows; ++y) {
      float* row = e.ptr<float>(y);
      for (int x = 0; x < e.cols; ++x)
        row[x] *= static_cast<float>(1 - s.vignetting * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max);
    }
  }
  if (s.defocus_sigma_px > 0) cv::GaussianBlur(e, e, cv::Size(0, 0), s.defocus_sigma_px, 0, cv::BORDER_REFLECT);
  const double max_dn = s.bits == 16 ? 65535.0 : 255.0;
  const double dn_per_electron = max_dn / s.full_well;
  std::mt19937_64 rng(Mix(impl_->scene.seed ^ Mix(0x5e55000ULL + view)));
  std::normal_distribution<double> gauss(0, 1);
  cv::Mat out(e.rows, e.cols, s.bits == 16 ? CV_16U : CV_8U);
  for (int y = 0; y < e.rows; ++y) {
    const float* row = e.ptr<float>(y);
    for (int x = 0; x < e.cols; ++x) {
      double electrons = std::max(0.0, s.exposure * row[x]);
      if (s.shot_noise && electrons > 0) {
        // Exact Poisson below 1000 electrons; beyond, its normal limit (relative error < 1e-3).
        if (electrons < 1000) {
          electrons = std::poisson_distribution<int>(electrons)(rng);
        } else {
          electrons += std::sqrt(electrons) * gauss(rng);
        }
      }
      if (s.read_noise > 0) electrons += s.read_noise * gauss(rng);
      const double dn = std::clamp(std::round(electrons * dn_per_electron), 0.0, max_dn);
      if (s.bits == 16) {
        out.at<uint16_t>(y, x) = static_cast<uint16_t>(dn);
      } else {
        out.at<uint8_t>(y, x) = static_cast<uint8_t>(dn);
      }
    }
  }
  return out;
}

bool Renderer::CameraRay(double u, double v, Vec3* direction) const {
  const Impl& I = *impl_;
  const double gx = u + 0.5, gy = v + 0.5;  // corner-grid coordinates
  if (!(gx >= 0 && gy >= 0 && gx <= I.W && gy <= I.H)) return false;
  const int x = std::min(static_cast<int>(gx), I.W - 1), y = std::min(static_cast<int>(gy), I.H - 1);
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
  if (!impl_->Nearest(impl_->AllCandidates(view, origin), origin, d, &h, &prim)) return std::nullopt;
  return RayHit{h.t, origin + h.t * d, prim};
}

bool Renderer::InSunShadow(int view, const Vec3& point) const {
  const Sun* sun = impl_->SunOf(view);
  if (!sun) return false;
  // Offset toward the sun so a point on a surface does not shadow itself.
  return impl_->Shadowed(view, point + kShadowOffset * sun->to_sun_world, sun->to_sun_world, -1);
}

}  // namespace svms
