// The renderer's insides, shared by the files that implement it (not installed):
//   render.cc         setting up (primitives from the scene, the camera's corner rays), the
//                     frame of a view, and the loop over tiles and blocks;
//   cull.cc           what a tile's, a block's or a pixel's rays may hit, and which shadow
//                     casters a sun ray may meet;
//   trace.cc          rays against primitives: the nearest hit, and shadows;
//   pixel.cc          a block's pixels: their random numbers, tracing and shading, sample by
//                     sample;
//   fused_pixel.cc    the planned pixels' shortcuts (earth only, one box face, a face with
//                     decals), which give the same bits as pixel.cc's general path;
//   background.cc     what a ray that hits nothing sees (the procedural earth, an image);
//   edge_pixels.cc    the second pass over edge pixels (sensor.edge_rays_per_pixel);
//   sensor.cc         the sensor and the camera's transfer (Expose) and the view files;
// with printed_pattern.h (what is printed where), render_hash.h (the random numbers),
// render_math.h and render_simd.h (the arithmetic, scalar and two lanes at a time).
//
// The primitives are boxes, rectangles (planes), spheres (occluders) and markers (a decal on
// its z = 0 plane, a post or a well along its z axis), each with a world_from_local pose; a ray
// is intersected in the primitive's local frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "svms/base/status.h"
#include "svms/geometry/pose.h"
#include "svms/sim/render.h"
#include "svms/sim/render_hash.h"
#include "svms/sim/render_math.h"
#include "svms/sim/render_simd.h"
#include "svms/sim/scene.h"

namespace svms::render {

constexpr double kEps = 1e-9;           // minimum ray distance, metres
constexpr double kCoplanarWin = 1e-7;   // a marker wins over a coplanar surface by this much
constexpr double kShadowOffset = 1e-6;  // shadow rays start this far off the surface
constexpr int kTile = 16;               // pixels per culling tile side
constexpr int kBlock = 4;               // pixels per classification block side (inside a tile)
constexpr int kGroup = 4;               // pixels whose random numbers are drawn together
constexpr int kMaxFused = 64;           // samples per pixel the fused pixel paths handle

// What a surface point looks like.
struct Surface {
  double reflectance = 0;
  bool retro = false;
  double retro_gain = 0;
  double specular = 0, shininess = 1;
  Vec3 normal = Vec3::Zero();  // world, facing the incoming ray
  int well_prim = -1;          // inside the well of this marker primitive (its walls may shade)
};

// One primitive of the scene (world frame through its pose), with the bounding spheres culling
// tests it by.
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

// A primitive that a tile's rays may hit, with the ray origin in its local frame.
struct Candidate {
  int prim;
  Vec3 local_origin;
  bool no_post = false;  // its post (if any) cannot be hit by the rays at hand
};

// Where the sun rays of a pixel (or a block) that are lit start: the box [lo, hi] bounding
// their starting points, and the one primitive all of them start on.
struct LitBounds {
  bool any = false;  // some sun ray meets its surface from the front (cosine > 0)
  int prim = -1;     // the primitive all of them start on; -1 none, -2 several
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  void Add(const Vec3& start, int on_prim) {
    any = true;
    lo = lo.cwiseMin(start);
    hi = hi.cwiseMax(start);
    prim = prim == -1 || prim == on_prim ? on_prim : -2;
  }
};

}  // namespace svms::render

namespace svms {

struct Renderer::Impl {
  using Vec3 = render::Vec3;
  using Mat3 = render::Mat3;
  using Prim = render::Prim;
  using LocalHit = render::LocalHit;
  using Candidate = render::Candidate;
  using LitBounds = render::LitBounds;
  using Rng = render::Rng;
  using F64x2 = render::F64x2;
  using V2 = render::V2;

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
    std::vector<Candidate> pixel_cands[render::kGroup];  // of the pixels at hand
    std::vector<int> idx;                                // samples a loop works on
    std::vector<Vec3> grid;                              // the block's corner rays (world, unit)
    std::vector<Candidate> block_cands;
    std::vector<Caster> pixel_casters;
    std::vector<double> ray;  // a pixel's camera rays (see CameraRays)
  };

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

  // What CoveredPixel records of each sample (fused_pixel.cc).
  struct CoveredSamples;

  const Sun* SunOf(int view) const {
    if (scene.views[view].sun) return &*scene.views[view].sun;
    return scene.light.sun ? &*scene.light.sun : nullptr;
  }
  // The seed of pixel (x, y)'s random numbers in view `view`.
  uint64_t PixelSeed(int view, int x, int y) const {
    return scene.seed ^
           render::Mix((static_cast<uint64_t>(view) << 40) ^ (static_cast<uint64_t>(y) << 20) ^ x);
  }
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

  // render.cc: setting up, and a view's frame.
  Status Build();
  // The radiance of a view on this Impl's grid (RenderRadiance's body): the first pass, then
  // RefineEdges where sensor.edge_rays_per_pixel asks for more samples than rays_per_pixel.
  cv::Mat Render(int view) const;
  // The first pass alone: rays_per_pixel samples per pixel.
  cv::Mat FirstPass(const Frame& f) const;
  // RenderRadianceFine's body, this Impl being the camera's grid and `fine` a Finer copy of it:
  // see render.cc.
  cv::Mat RenderFine(const Impl& fine, int view) const;
  // A copy on a grid `factor` times finer: corner rays blended from this one's, the samples per
  // pixel divided by factor^2 (at least 1), the backdrop resampled.
  std::unique_ptr<Impl> Finer(int factor) const;
  Status NormaliseSunDirections();
  Status UnprojectCorners();
  void AddSceneObjects();
  std::vector<int> AddOccluders(const std::vector<Occluder>& occluders);
  Frame MakeFrame(int view) const;

  // cull.cc: what rays may hit.
  void TileCandidates(const Frame& f, int tx, int ty, int x1, int y1,
                      std::vector<Candidate>* out) const;
  void ConeCandidates(const Frame& f, const Vec3* c, int nc, const std::vector<Candidate>& tile,
                      std::vector<Candidate>* out, PixelPlan* plan) const;
  bool BoxCoversRays(const Frame& f, const Vec3* c, int nc, const Prim& p, const Vec3& lo,
                     PixelPlan* plan) const;
  static bool DecalMayMeetRays(const Prim& p, const Vec3& lo, const Vec3* c, int nc);
  std::vector<Caster> Casters(int view, const Sun* sun) const;
  void CullCasters(const Frame& f, const Vec3& lo, const Vec3& hi, std::vector<Caster>* out,
                   int self_box) const;
  const std::vector<Caster>* PixelCasters(const Frame& f, Scratch* sc, const LitBounds& lit) const;

  // trace.cc: rays against primitives.
  bool Intersect(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
                 bool no_post = false) const;
  bool IntersectMarker(const Prim& p, const Vec3& o, const Vec3& d, LocalHit* h,
                       bool no_post) const;
  bool FaceHit(const Candidate& c, const PixelPlan& plan, const Vec3& d, LocalHit* h) const;
  bool Nearest(const std::vector<Candidate>& candidates, const Vec3& o, const Vec3& d,
               LocalHit* best, int* best_prim) const;
  bool NearestCovered(const std::vector<Candidate>& candidates, const PixelPlan& plan,
                      const Vec3& o, const Vec3& d, LocalHit* best, int* best_prim) const;
  void AllCandidates(int view, const Vec3& o, std::vector<Candidate>* out) const;
  std::vector<Candidate> AllCandidates(int view, const Vec3& o) const;
  bool Shadowed(const Vec3& x, const Vec3& s, int well_prim, const std::vector<Caster>& casters,
                int self = -1) const;

  // pixel.cc: a block's pixels, sample by sample.
  void RenderBlock(const Frame& f, int x0, int y0, int x1, int y1,
                   const std::vector<Candidate>& candidates, Scratch* scratch, cv::Mat* out) const;
  double RenderPixel(const Frame& f, const PixelJob& job, const std::vector<Caster>* casters,
                     Scratch* sc) const;
  void TraceSamples(const Frame& f, const PixelJob& J, Scratch* sc) const;
  void TracePixel(const Frame& f, int x, int y, const std::vector<Candidate>& cands,
                  Sample* samples, Scratch* sc) const;
  void BackgroundSamples(int nn, Sample* samples, int* idx) const;
  int SurfacePoints(int nn, Sample* samples, int* idx) const;
  LitBounds SunRays(const Frame& f, Sample* samples, const int* idx, int m) const;
  double ShadeSamples(const Frame& f, const Sample* samples, int nn,
                      const std::vector<Caster>& casters) const;
  double Shade(const Frame& f, const Sample& smp, const std::vector<Caster>& casters) const;
  Pose WorldFromCam(const Frame& f, double tau) const;

  // fused_pixel.cc: the planned pixels' shortcuts.
  bool FusedPixel(const Frame& f, const PixelJob& J, const std::vector<Caster>* casters,
                  Scratch* sc, double* radiance) const;
  void CameraRays(const Frame& f, const PixelJob& J, double* ray) const;
  double EarthPixel(const Frame& f, const PixelJob& J, double* ray) const;
  bool FacePixel(const Frame& f, const PixelJob& J, double* ray, double* radiance) const;
  bool CoveredPixel(const Frame& f, const PixelJob& J, double* ray,
                    const std::vector<Caster>* casters, Scratch* sc, double* radiance) const;
  bool CoveredDecals(const PixelJob& J, CoveredSamples* s) const;
  bool CoveredHits(const Frame& f, const PixelJob& J, const double* ray, CoveredSamples* s) const;
  LitBounds CoveredSunRays(const Frame& f, const PixelJob& J, const double* ray,
                           CoveredSamples* s) const;

  // background.cc: what a ray that hits nothing sees.
  void BuildEarth();
  Status LoadBackdrop();
  double BackgroundRadiance(const Vec3& d_world, double px, double py) const;
  void EarthRadiance2(const V2& d, double* a, double* b) const;
  static void EarthAngles2(const V2& d, F64x2* lon, F64x2* lat);
  static EarthRef MakeEarthRef(const Vec3& d0);
  void EarthNear2(const EarthRef& r, const V2& d, double* a, double* b) const;
  void EarthLookup2(F64x2 lon, F64x2 lat, double* a, double* b) const;
  static double Bilinear(const cv::Mat& img, double u, double v, bool wrap_x);

  // edge_pixels.cc: the second pass over edge pixels.
  void RefineEdges(const Frame& f, cv::Mat* out) const;
  // Renders the pixels set in `mask` (CV_8U, this grid's size) of *out again from scratch, each
  // the mean of n x n jittered samples through the general per-sample path.
  void RenderAgain(const Frame& f, int n, const cv::Mat& mask, cv::Mat* out) const;
};

}  // namespace svms
