// The scene simulator's renderer: ray casting through exact geometry with stratified
// supersampling, then a sensor model. Everything a later claim is measured on comes from here,
// so the geometry is exact (planes, cylinders, spheres, boxes; the printed pattern looked up
// analytically) and the camera rays come from mrcal's unprojection of the scene's lens model.
//
// Camera rays: mrcal unprojects every pixel corner once per renderer; a ray through a point
// inside a pixel is the bilinear blend of its four corner rays (the lens is smooth at that
// scale: the blend, stored as floats, is within 1e-4 px of mrcal's own unprojection; measured
// 4.4e-5 px for an OPENCV8 lens, tested).
//
// Thread-safe: one Renderer may render several views at once from several threads.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/imageio/image_io.h"
#include "svms/sim/scene.h"

namespace svms {

// Radiance (units of white paper facing the sun): under a third of the shot noise of a sunlit
// white print, and above the first pass's own noise where nothing but the sun's disc is sampled
// (0.0003-0.0005 RMS on a lit white, so 0.0008-0.0012 RMS in a second difference). A pixel is
// on an edge (EdgePixels) where the second difference of the first pass's radiance through it,
// along a row, a column or a diagonal, exceeds it.
constexpr double kEdgeRadianceStep = 0.004;
// Radiance by which a pixel must differ from one of its eight neighbours to be on an edge
// whatever its second differences: a pixel half covered by a straight edge sits on a straight
// ramp. Five times kEdgeRadianceStep, so a smooth shading gradient of under 0.02 per pixel is
// not taken for an edge.
constexpr double kEdgeRadianceJump = 0.02;

// The pixels (CV_8U, 1 = edge) that sensor.edge_rays_per_pixel renders again, from the first
// pass's radiance (CV_32FC1). Pixels on the image border test only the neighbours they have.
// Why second differences: a first difference of kEdgeRadianceStep also flags smooth shading
// and the sun disc's sampling noise (20-50 % of a mockup view's pixels against 2-5 %), which
// makes a 200-view mockup render 9 times slower for no gain.
cv::Mat EdgePixels(const cv::Mat& radiance);

// What a ray hits first.
struct RayHit {
  double t = 0;           // distance along the (unit) ray, metres
  Eigen::Vector3d point;  // world frame
  int primitive = -1;     // internal index; -1 = background
};

// The memory a render of `scene` needs with `threads` views in flight, bytes: the renderer's
// per-pixel state and, per view, its radiance, edge map, exposure and encoded image. Measured
// (docs/reliability.md) and rounded up, so that `svms render` refuses a scene that cannot fit
// (memory_limit.h) before it starts.
double RenderMemoryBytes(const Scene& scene, int threads);

// The extension of the image file a view is written to: ".png", or ".jpg" for format "jpeg".
std::string ViewFileExtension(const Sensor& sensor);

// How `svms render` encodes a view: a PNG declares the sensor's response (gAMA 1.0 for linear,
// an sRGB chunk for srgb, gAMA 1/G for gamma:G) so that a reader recovers the light; a JPEG is
// written by libjpeg (OpenCV's encoder) at sensor.jpeg_quality.
ImageEncoding ViewImageEncoding(const Sensor& sensor);

// The pixels a reader decodes from the file `svms render` writes of `exposed` (Expose's output
// for `sensor`): for a JPEG, `exposed` encoded by the very call that writes the file
// (EncodeImage, libjpeg) and decoded by cv::imdecode as image_io.h's loaders decode it; a PNG is
// lossless, so `exposed` itself. For benchmarks that measure in-process what a file would give.
// Errors: the encoder or decoder failed (an image that is not what Expose makes for `sensor`).
Status ThroughCodec(const Sensor& sensor, const cv::Mat& exposed, cv::Mat* decoded);

// Whether a Renderer made for a scene with sensor `a` renders, for every view, the same
// RenderRadianceFor(view, b) as for `a`: the same rays per pixel, on edges too, the same motion
// blur, and a defocus blur in both or in neither (the grid the light is cast on). Exposing one
// radiance through both then gives what two renders would (Expose's noise depends on the scene's
// seed and the view only).
bool SharesRadiance(const Sensor& a, const Sensor& b);

// How much finer than the camera's pixels RenderRadianceFine renders: on a 1-D edge behind a
// Gaussian of 0.7 px, a blur on the pixel grid errs by up to 4.0 % of the edge's contrast in a
// pixel, on a grid 2 times finer by 0.8 %, 4 times finer by 0.2 % (docs/simulator.md).
constexpr int kRadianceSupersample = 4;

class Renderer {
 public:
  // Prepares the geometry and unprojects the camera's pixel-corner grid (about 1 s for a
  // 1024x1024 OPENCV8 camera). Fails if the camera cannot unproject its own image.
  static Status Create(const Scene& scene, std::unique_ptr<Renderer>* out);
  ~Renderer();

  // Noise-free radiance of view `view` (CV_32FC1, the camera's size): the mean of
  // rays_per_pixel stratified samples per pixel, each shaded with sun (finite disc, shadows),
  // ambient, earthshine, ring light and specular glare; with sensor.edge_rays_per_pixel, the
  // pixels on an edge (EdgePixels) the mean of that many instead.
  cv::Mat RenderRadiance(int view) const;
  // The radiance of view `view` on a grid kRadianceSupersample times finer in each direction
  // (CV_32FC1, that many times the camera's width and height): the light before the pixels
  // integrate it, which a lens's defocus acts on (Expose blurs it there and then integrates the
  // pixels). Within each pixel on an edge of RenderRadiance's first pass (EdgePixels) or next
  // to one, each fine pixel is the mean of max(rays_per_pixel, edge_rays_per_pixel) /
  // kRadianceSupersample^2 samples (its square root rounded up), cast through the bilinear blend
  // of the pixel-corner rays (as within a pixel); every other pixel's fine pixels carry the
  // first pass's value of that pixel (render.cc says why, and what it costs).
  cv::Mat RenderRadianceFine(int view) const;
  // RenderRadianceFine where `sensor` blurs (defocus_sigma_px > 0), else RenderRadiance: what
  // Expose needs for it.
  cv::Mat RenderRadianceFor(int view, const Sensor& sensor) const;

  // The sensor and the camera's transfer, in a real camera's order: vignetting, defocus blur
  // (on a radiance from RenderRadianceFine: blurred on the fine grid, then each pixel the mean of
  // its fine pixels, as a pixel integrates the blurred light; on a radiance at the camera's size:
  // blurred on the pixel grid, which a sharp edge's sub-pixel phase bends by up to 4 % of its
  // contrast at 0.7 px, docs/simulator.md);
  // electrons (exposure x radiance, times the pixel's channel_gain under a Bayer filter); shot
  // and read noise, in electrons; s = electrons / full_well clipped to [0, 1] (a lossless linear
  // frame with a whole-number black level: below 0 down to -black, docs/simulator.md); the response
  // e = FromLinear(s); DN = black_level + e * (white_level - black_level), rounded and clipped to
  // the container (CV_8UC1 or CV_16UC1, one channel also for a mosaic). The default sensor
  // gives DN = round(electrons * (2^bits - 1) / full_well). Deterministic for a given scene
  // seed and view.
  cv::Mat Expose(const cv::Mat& radiance, int view) const;
  // The same through `sensor` (which must pass CheckSensor) in place of the scene's, with the
  // same noise seed: one render seen through several camera pipelines (sensor profiles).
  cv::Mat Expose(const cv::Mat& radiance, int view, const Sensor& sensor) const;

  // First surface along a world ray (direction need not be unit length) in view `view`
  // (occluders can change per view).
  std::optional<RayHit> Cast(int view, const Eigen::Vector3d& origin,
                             const Eigen::Vector3d& direction) const;
  // True if the centre of the sun is hidden from `point` (world) in view `view`; false when
  // there is no sun.
  bool InSunShadow(int view, const Eigen::Vector3d& point) const;

  // The camera-frame ray (unit) through pixel position (u, v) as the renderer casts it: the
  // bilinear blend of the four surrounding pixel-corner rays. False outside the image.
  bool CameraRay(double u, double v, Eigen::Vector3d* direction) const;

  const Scene& scene() const;

 private:
  Renderer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  // The fine grid's (RenderRadianceFine), built once from impl_, whose scene its primitives
  // point into: declared after impl_, so destroyed before it.
  mutable std::unique_ptr<Impl> fine_;
  mutable std::once_flag fine_once_;
};

}  // namespace svms
