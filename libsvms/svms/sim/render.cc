// The renderer (render.h): setting up a scene (its primitives, the camera's pixel-corner rays,
// the background), the frame of one view, and the loop over an image's tiles and blocks. How
// the work is divided between the files that implement it: render_impl.h.
#include "svms/sim/render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "svms/codec/svms44.h"
#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

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
  if (Status s = NormaliseSunDirections(); !s) return s;
  if (!ValidEdgeRays(scene.sensor))
    return Status::Error(
        "sensor.edge_rays_per_pixel: expected 0 (off), or a square number of at "
        "most 4096, got " +
        std::to_string(scene.sensor.edge_rays_per_pixel));
  W = scene.camera.width();
  H = scene.camera.height();
  if (Status s = UnprojectCorners(); !s) return s;
  AddSceneObjects();
  const size_t n_static = prims.size();
  const std::vector<int> shared = AddOccluders(scene.occluders);
  view_prims.resize(scene.views.size());
  for (size_t v = 0; v < scene.views.size(); ++v) {
    for (size_t i = 0; i < n_static; ++i) view_prims[v].push_back(static_cast<int>(i));
    const std::vector<int> occ =
        scene.views[v].occluders ? AddOccluders(*scene.views[v].occluders) : shared;
    view_prims[v].insert(view_prims[v].end(), occ.begin(), occ.end());
  }
  if (scene.background.kind == Background::Kind::kEarth) BuildEarth();
  if (scene.background.kind == Background::Kind::kImage) return LoadBackdrop();
  return Status::Ok();
}

// Makes the scene's directions toward the sun (and earthshine) unit vectors: the JSON parser
// normalises them, scenes built in code may not. Fails on a zero or non-finite one.
Status Renderer::Impl::NormaliseSunDirections() {
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
  return Status::Ok();
}

// The camera rays through the pixel corners (corner_dirs): corner (i, j) is the pixel
// coordinate (i - 0.5, j - 0.5). Fails if the lens unprojects none of them.
Status Renderer::Impl::UnprojectCorners() {
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
  return Status::Ok();
}

// The primitives of the scene's objects and of the markers on them (world frame). A marker
// primitive points into scene.objects, which no longer changes.
void Renderer::Impl::AddSceneObjects() {
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
}

// The primitives of `occluders` (bars as boxes, spheres), appended to prims: their indices.
std::vector<int> Renderer::Impl::AddOccluders(const std::vector<Occluder>& occluders) {
  std::vector<int> idx;
  for (const Occluder& o : occluders) {
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

// How an image is rendered (one core; about 0.9 s for a 1024 x 1024 image at 16 rays per
// pixel, bench/micro/render_bench.cc): 16 x 16 pixel tiles keep the primitives their cone of rays
// may meet; 4 x 4 blocks, then pixels, narrow that down (ConeCandidates) and find out which
// pixels see only the background or lie inside one box face; those pixels' random numbers are
// drawn up front and their samples traced and shaded in tight loops (EarthPixel, FacePixel,
// CoveredPixel), the others one sample after another (TracePixel, RenderPixel). Every shortcut
// either does the same floating-point operations as the general path, in the same order, or
// leaves out work whose result is provably not used (a primitive no ray can reach, a shadow
// caster no sun ray can reach): the images are the same to the bit as the straightforward
// per-sample renderer's. The one exception is the earth's longitude and latitude, computed
// within a few ulp of libm's (EarthRef), which moves a radiance by float rounding at most.
cv::Mat Renderer::RenderRadiance(int view) const { return impl_->Render(view); }

cv::Mat Renderer::RenderRadianceFine(int view) const {
  std::call_once(fine_once_, [this] { fine_ = impl_->Finer(kRadianceSupersample); });
  return impl_->RenderFine(*fine_, view);
}

bool SharesRadiance(const Sensor& a, const Sensor& b) {
  return a.rays_per_pixel == b.rays_per_pixel && a.edge_rays_per_pixel == b.edge_rays_per_pixel &&
         a.motion_blur == b.motion_blur && (a.defocus_sigma_px > 0) == (b.defocus_sigma_px > 0);
}

cv::Mat Renderer::RenderRadianceFor(int view, const Sensor& sensor) const {
  return sensor.defocus_sigma_px > 0 ? RenderRadianceFine(view) : RenderRadiance(view);
}

std::unique_ptr<Renderer::Impl> Renderer::Impl::Finer(int factor) const {
  auto fine = std::make_unique<Impl>(*this);
  fine->W = W * factor;
  fine->H = H * factor;
  // Fine corner (i, j) is the point (i / factor, j / factor) of this grid's corner lattice.
  fine->corner_dirs.assign(static_cast<size_t>(fine->W + 1) * (fine->H + 1),
                           Eigen::Vector3f::Constant(NAN));
  auto at = [&](int i, int j) { return corner_dirs[static_cast<size_t>(j) * (W + 1) + i]; };
  for (int j = 0; j <= fine->H; ++j)
    for (int i = 0; i <= fine->W; ++i) {
      const int x = std::min(i / factor, W - 1), y = std::min(j / factor, H - 1);
      const float fx = static_cast<float>(i - x * factor) / factor,
                  fy = static_cast<float>(j - y * factor) / factor;
      // Only the corners with weight: an exact coarse corner next to an invalid one stays valid.
      Eigen::Vector3f d = Eigen::Vector3f::Zero();
      const float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      const Eigen::Vector3f c[4] = {at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1)};
      for (int k = 0; k < 4; ++k)
        if (w[k] > 0) d += w[k] * c[k];
      if (d.allFinite())
        fine->corner_dirs[static_cast<size_t>(j) * (fine->W + 1) + i] = d.normalized();
    }
  // Samples per fine pixel side: the pixel's, divided by the factor and rounded up.
  auto fewer = [factor](int rays) {
    if (rays <= 0) return rays;
    const int n = (static_cast<int>(std::lround(std::sqrt(rays))) + factor - 1) / factor;
    return n * n;
  };
  fine->scene.sensor.rays_per_pixel = fewer(scene.sensor.rays_per_pixel);
  fine->scene.sensor.edge_rays_per_pixel = fewer(scene.sensor.edge_rays_per_pixel);
  if (!backdrop.empty())
    cv::resize(backdrop, fine->backdrop, cv::Size(fine->W, fine->H), 0, 0, cv::INTER_LINEAR);
  return fine;
}

cv::Mat Renderer::Impl::Render(int view) const {
  const Frame f = MakeFrame(view);
  cv::Mat out = FirstPass(f);
  if (scene.sensor.edge_rays_per_pixel > scene.sensor.rays_per_pixel) RefineEdges(f, &out);
  return out;
}

// The fine grid is rendered where the light changes within a camera pixel, and taken from the
// camera's grid elsewhere: the first pass on the camera's grid (rays_per_pixel stratified
// samples per pixel, as RenderRadiance), its edge pixels (EdgePixels), then each fine pixel of
// an edge pixel or of one of its 8 neighbours rendered anew with the fine grid's samples
// (rays_per_pixel, or edge_rays_per_pixel where that is more, divided by factor^2: the same
// number per camera pixel) and every other fine pixel the value of the camera pixel it lies in.
//
// Why not the first pass on the fine grid itself: one sample per fine pixel there samples the
// sun's disc alone (16 rays per pixel: 0.0003-0.0005 RMS on a lit white, render.h) 4 times as
// noisily, which trips EdgePixels' second-difference test on every lit surface (about a third of
// the fine pixels of a range view, all rendered again), and the per-pixel work of the first pass
// is paid 16 times: `svms render` of a 1024 x 1024 range view took 16.5 s, against 2.4 s
// without a defocus (4.1 s this way; docs/simulator.md).
//
// What the copy costs: nothing where the light is flat. Where it varies smoothly (below
// EdgePixels' thresholds), a camera pixel's fine pixels carry its mean instead of the slope
// across it; after a symmetric blur, a pixel's mean over its fine pixels is the same for a
// staircase as for the linear light it steps along (each pixel's mean is its centre's value,
// and the blur's weights are symmetric), so only the curvature within a pixel is lost.
// A step of contrast C at the middle of a pixel is another matter: that pixel's second
// differences vanish and its first ones are C / 2, so below C = 2 kEdgeRadianceJump (a marker
// in shadow: ambient 0.04 times its print's contrast) EdgePixels leaves it out and only its
// neighbours in, whose second differences are C / 2. Copied, the step would be blurred as on
// the pixel grid, wrong by about 5 % of C beside it. Hence the neighbours: every step of
// C > 2 kEdgeRadianceStep is cast on the fine grid, and the copies err by at most about 5.6 %
// of that, 0.00045 of white (Render.TheFineGridIsRenderedWhereTheLightChangesWithinAPixel: a
// marker in shadow, without the neighbours, 5 % of its contrast).
cv::Mat Renderer::Impl::RenderFine(const Impl& fine, int view) const {
  const int k = fine.W / W;
  const cv::Mat coarse = FirstPass(MakeFrame(view));
  cv::Mat edge;
  cv::dilate(EdgePixels(coarse), edge, cv::Mat::ones(3, 3, CV_8U));
  cv::Mat out(fine.H, fine.W, CV_32F), mask(fine.H, fine.W, CV_8U);
  for (int y = 0; y < fine.H; ++y) {
    const float* c = coarse.ptr<float>(y / k);
    const uint8_t* e = edge.ptr<uint8_t>(y / k);
    float* o = out.ptr<float>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < fine.W; ++x) {
      o[x] = c[x / k];
      m[x] = e[x / k];
    }
  }
  const Sensor& s = fine.scene.sensor;
  const int n = static_cast<int>(
      std::lround(std::sqrt(std::max({1, s.rays_per_pixel, s.edge_rays_per_pixel}))));
  fine.RenderAgain(fine.MakeFrame(view), n, mask, &out);
  return out;
}

cv::Mat Renderer::Impl::FirstPass(const Frame& f) const {
  const Impl& I = *this;
  cv::Mat out(I.H, I.W, CV_32F, cv::Scalar(0));
  const bool moving = f.moving;
  std::vector<Candidate> candidates;
  Impl::Scratch scratch;
  scratch.idx.resize(static_cast<size_t>(f.n) * f.n);
  scratch.ray.resize(3 * (static_cast<size_t>(f.n) * f.n + 2));
  for (int ty = 0; ty < I.H; ty += kTile) {
    for (int tx = 0; tx < I.W; tx += kTile) {
      const int x1 = std::min(I.W, tx + kTile), y1 = std::min(I.H, ty + kTile);
      I.TileCandidates(f, tx, ty, x1, y1, &candidates);
      // Nothing to hit and a black sky: the tile stays black.
      if (!moving && candidates.empty() && I.scene.background.kind == Background::Kind::kBlack)
        continue;
      for (int by = ty; by < y1; by += kBlock)
        for (int bx = tx; bx < x1; bx += kBlock)
          I.RenderBlock(f, bx, by, std::min(x1, bx + kBlock), std::min(y1, by + kBlock), candidates,
                        &scratch, &out);
    }
  }
  return out;
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

double RenderMemoryBytes(const Scene& scene, int threads) {
  const double pixels = static_cast<double>(scene.camera.width()) * scene.camera.height();
  // Measured peak resident memory of `svms render`: 51 bytes per pixel above a 60 MB base at
  // 4, 9 and 16 megapixels, the same with 1, 2 and 4 threads (the renderer's per-pixel state,
  // built by Create, dominates: the pixel-corner rays and their unprojection). Counted as 56
  // per pixel, plus 16 per pixel for each view in flight (radiance, edges, exposure, encoding).
  // Behind a defocus (RenderRadianceFine), the fine grid's corner rays (12 bytes per fine
  // corner; about 200 MB for a 1024 x 1024 camera) and, per view in flight, its radiance, blur
  // and mask of the pixels rendered on it (9 bytes per fine pixel, about 150 MB), counted from
  // the arrays' sizes, not measured.
  const double fine =
      scene.sensor.defocus_sigma_px > 0 ? kRadianceSupersample * kRadianceSupersample * pixels : 0;
  // An image background is resampled onto the fine grid too (4 bytes per fine pixel).
  const double backdrop = scene.background.kind == Background::Kind::kImage ? 4 * fine : 0;
  return 56 * pixels + 16 * pixels * std::max(threads, 1) + 12 * fine + backdrop +
         9 * fine * std::max(threads, 1) + 100e6;
}

}  // namespace svms
