#include "svms/detect/marker_pose.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>

#include "svms/base/thread_scratch.h"
#include "svms/codec/svms44.h"
#include "svms/detect/corner_refine.h"
#include "svms/detect/disc_fit.h"
#include "svms/detect/ippe.h"
#include "svms/detect/pose_gauss_newton.h"
#include "svms/geometry/pose_matrix.h"
#include "svms/geometry/quad_sides.h"

namespace svms {
namespace {

// Per axis, pixels: what the top's disc fit leaves unmodelled (see FindTip). Measured on the
// compare size sweep (seed 2, 256 rays on edge pixels, 72-142 views per size) as the floor
// that makes the tip's per-axis Z^2 near 1: at 0.02 it is 0.75 / 0.87 / 1.01 / 0.67 / 0.93 /
// 1.15 / 1.28 at 8 / 10 / 12 / 16 / 20 / 30 / 60 px; at 0.03 it is 0.41-0.73.
constexpr double kTipDiscModelSigma = 0.02;
// Tops up to this radius in the image (pixels) are located by the disc fit, larger ones by
// their centroid (FindTip). In the size sweep of `svms bench compare` (40 views per size, the
// truth of the simulator) the centroid of a 1-2 px top scatters 0.08-0.14 px RMS against
// its sigma of 0.05 (pixel locking, as below a pixel), the disc fit 0.03-0.05 px; at 6 px
// (120 px markers) both are at 0.04.
constexpr double kMaxDiscFitRadiusPx = 5;
// The fit's window, 2 ceil(r + 1.5) + 1 pixels across, must fit FitDisc's 16.
static_assert(2 * (static_cast<int>(kMaxDiscFitRadiusPx) + 2) + 1 <= 16);
// Where such a top is left to its centroid (something bright beside it, the image's border),
// the centroid's pixel locking, per axis, is about this many pixels over the top's radius
// (0.13 px RMS at a radius of 1.2 px, 0.05 at 2, 0.03 at 3.5: FindTip's tests).
constexpr double kCentroidLockingPxPx = 0.15;

// Ring pixels of a sub-pixel top closer than this to a side of the square, or outside it, are
// not held dark (FindTip's `square`): a blurred edge's light at a pixel centre d px inside
// falls below a tenth of the contrast (where a top's ring test starts) beyond d = 1.3 sigma,
// and 1.5 px covers a lens blur of up to 1 px with the pixel's own width.
constexpr double kTipRingEdgeMarginPx = 1.5;
// ... and only where the seed is at least this far from the second-nearest side: the ring's
// reach (2 px) and half a pixel, so that by a corner, where two sides' light meets, the ring
// test applies. Geometry, not fitted; behind 0.7 px of blur a side's light half a pixel beyond
// the ring is about a quarter of the contrast, and it is the ring test, not this margin, that
// keeps the stripe's corner from passing for a top (FindTip's tests).
constexpr double kTipCornerReachPx = 2.5;
// A top below a pixel that stands out by its light alone (not its peak) must hold this many
// standard deviations of its own noise: a one-sided 5 sigma (3 x 10^-7) for a known noise,
// before the choice of the seed (the brightest of some 30 pixels) and the spread of a noise
// read from 16 pixels, which raise the chance of a flat patch passing by orders of magnitude
// (BlurredTopStandsOut).
constexpr double kBlurredTopSigmas = 5;

// Adds one residual row J = [jr^T, jt^T] (rotation, translation), weight w, residual r to the
// upper triangle of JtWJ and to JtWr. Written out: Eigen's rankUpdate and comma initialiser
// on 6-vectors are not inlined and cost more than the projection.
inline void AddRow(const Eigen::Vector3d& jr, const Eigen::Vector3d& jt, double w, double r,
                   Eigen::Matrix<double, 6, 6>* JtWJ, Eigen::Matrix<double, 6, 1>* JtWr) {
  const double j[6] = {jr.x(), jr.y(), jr.z(), jt.x(), jt.y(), jt.z()};
  for (int a = 0; a < 6; ++a) {
    const double wa = w * j[a];
    (*JtWr)(a) += wa * r;
    for (int b = a; b < 6; ++b) (*JtWJ)(a, b) += wa * j[b];
  }
}

// Buffers kept per thread between calls (no allocation once grown; the C API's promise).
struct PoseScratch {
  std::vector<std::pair<int, int>> stack, blob;  // FindTip's flood fill
  std::vector<uint8_t> seen;
  std::vector<Eigen::Vector3d> X;  // EstimateMarkerPose's points, pixels and sigmas
  std::vector<Eigen::Vector2d> px;
  std::vector<double> sigma;
  Eigen::Matrix<double, 8, 8> corner_whitener;  // CornerWhitener's
  TipSearchMemo tip_memo;  // EstimateMarkerPose's, shared by its planar candidates
};
PoseScratch& Scratch() { return ThreadScratch<PoseScratch>(); }

// The other planar candidate's weight in the covariance below which it is left out, and above
// which the pose is flagged ambiguous (EstimateMarkerPose).
constexpr double kMixtureWeightFloor = 1e-6;
constexpr double kAmbiguousWeight = 0.01;
// Nor is it flagged when the other is within this angle (degrees): a marker seen within a
// degree of head-on is its own twin for any use, and its covariance spans the difference.
// (Without it, 12 of the 31 poses flagged in `svms bench compare --size-views 40` are 14-40 px
// markers 0.1-2.8 degrees off-axis, 0.2-1.2 degrees from the truth.)
constexpr double kAmbiguousMinDeg = 2;

// When RefinePose stops: the step is a millionth of the pose's own standard deviation (its
// squared Mahalanobis length under J^T W J below 1e-12), or below 1e-12 (radians; translation
// relative to the range). Where noise leaves residuals and the fit is ill-conditioned (a small
// marker), Gauss-Newton converges only linearly: the fixed 1e-12 alone takes twice the
// iterations for no change a covariance could show. Rotation steps below 1e-15 rad are left
// out (they would move R by rounding only).
constexpr PoseStepTolerances kMarkerPoseTolerances{1e-12, 1e-12, 1e-15};

// Sum over the points of their squared reprojection error in units of their sigmas; with
// `corner_whitener` (FitPoints), the first four points' 8 residuals whitened by it instead.
double WeightedSquaredResiduals(const CameraModel& camera, const std::vector<Eigen::Vector3d>& X,
                                const std::vector<Eigen::Vector2d>& px,
                                const std::vector<double>& sigma, const Pose& pose,
                                const Eigen::Matrix<double, 8, 8>* corner_whitener) {
  double chi2 = 0;
  const bool joint = corner_whitener && X.size() >= 4;
  Eigen::Matrix<double, 8, 1> r8;
  for (size_t i = 0; i < X.size(); ++i) {
    Eigen::Vector2d q;
    if (!camera.Project(pose * X[i], &q)) return std::numeric_limits<double>::infinity();
    if (joint && i < 4)
      r8.segment<2>(2 * i) = q - px[i];
    else
      chi2 += (q - px[i]).squaredNorm() / (sigma[i] * sigma[i]);
  }
  if (joint) chi2 += (*corner_whitener * r8).squaredNorm();
  return chi2;
}

// A pixel of a CV_8U or CV_16U image as a grey level.
double Grey(const cv::Mat& img, int y, int x) {
  return img.depth() == CV_16U ? img.at<uint16_t>(y, x) : img.at<uint8_t>(y, x);
}

// FindTip's search window, pixels, inclusive.
struct TipWindow {
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
};

// The window of the image within `radius` of `pred` (clipped), and in it the brightest pixel
// nearest the prediction (*bx, *by; -1 if none within the radius). False if the window is
// empty.
bool TipSeed(const cv::Mat& img, const Eigen::Vector2d& pred, double radius, double black,
             double white, TipWindow* w, int* bx, int* by) {
  w->x0 = std::max(0, static_cast<int>(std::floor(pred.x() - radius)));
  w->x1 = std::min(img.cols - 1, static_cast<int>(std::ceil(pred.x() + radius)));
  w->y0 = std::max(0, static_cast<int>(std::floor(pred.y() - radius)));
  w->y1 = std::min(img.rows - 1, static_cast<int>(std::ceil(pred.y() + radius)));
  if (w->x0 > w->x1 || w->y0 > w->y1) return false;
  double best = -1;
  *bx = -1;
  *by = -1;
  for (int y = w->y0; y <= w->y1; ++y)
    for (int x = w->x0; x <= w->x1; ++x) {
      const double d2 = (x - pred.x()) * (x - pred.x()) + (y - pred.y()) * (y - pred.y());
      if (d2 > radius * radius) continue;
      const double v = Grey(img, y, x) - 0.02 * (white - black) * std::sqrt(d2);  // prefer near
      if (v > best) {
        best = v;
        *bx = x;
        *by = y;
      }
    }
  return true;
}

// Whether `memo` holds the answer of a FindTip call on `img` with these arguments, seeded at
// (bx, by) with threshold local_thr in window w (TipSearchMemo, marker_pose.h).
bool MemoAnswers(const TipSearchMemo& memo, const cv::Mat& img, double radius, double black,
                 double white, double min_contrast, double tip_radius_px, bool sub_pixel,
                 const TipWindow& w, int bx, int by, double local_thr,
                 const std::array<Eigen::Vector2d, 4>* square, double noise_sigma) {
  const int x0 = w.x0, x1 = w.x1, y0 = w.y0, y1 = w.y1;
  return memo.valid && memo.has_square == (square != nullptr) && memo.noise_sigma == noise_sigma &&
         (!square || memo.square == *square) && memo.data == img.data && memo.rows == img.rows &&
         memo.cols == img.cols && memo.type == img.type() && memo.radius == radius &&
         memo.black == black && memo.white == white && memo.min_contrast == min_contrast &&
         memo.tip_radius_px == tip_radius_px &&
         (sub_pixel
              ? memo.seed_x == bx && memo.seed_y == by
              : memo.local_thr == local_thr && memo.blob_x0 > x0 - (x0 == 0) &&
                    memo.blob_x1 < x1 + (x1 == img.cols - 1) && memo.blob_y0 > y0 - (y0 == 0) &&
                    memo.blob_y1 < y1 + (y1 == img.rows - 1) &&
                    std::find(memo.blob.begin(), memo.blob.end(), std::make_pair(bx, by)) !=
                        memo.blob.end());
}

// Sets `memo` to this FindTip call's arguments, seed and threshold (not yet valid: no answer).
void StartMemo(TipSearchMemo* memo, const cv::Mat& img, double radius, double black, double white,
               double min_contrast, double tip_radius_px, int bx, int by, double local_thr,
               const std::array<Eigen::Vector2d, 4>* square, double noise_sigma) {
  memo->valid = false;
  memo->noise_sigma = noise_sigma;
  memo->has_square = square != nullptr;
  if (square) memo->square = *square;
  memo->data = img.data;
  memo->rows = img.rows;
  memo->cols = img.cols;
  memo->type = img.type();
  memo->radius = radius;
  memo->black = black;
  memo->white = white;
  memo->min_contrast = min_contrast;
  memo->tip_radius_px = tip_radius_px;
  memo->seed_x = bx;
  memo->seed_y = by;
  memo->local_thr = local_thr;
  memo->blob.clear();
}

// How far `p` lies inside the quadrilateral `square` (pixels; corners in order around it,
// either way round) from each side k (from corner k to k + 1), negative outside it.
std::array<double, 4> SideDepths(const std::array<Eigen::Vector2d, 4>& square,
                                 const Eigen::Vector2d& p) {
  const std::array<Eigen::Vector2d, 4> outward = QuadOutwardNormals(square);
  std::array<double, 4> depth;
  for (int k = 0; k < 4; ++k) depth[k] = -outward[k].dot(p - square[k]);
  return depth;
}

// How far `p` lies inside `square` from its nearest side (SideDepths).
double DepthInSquare(const std::array<Eigen::Vector2d, 4>& square, const Eigen::Vector2d& p) {
  const std::array<double, 4> depth = SideDepths(square, p);
  return *std::min_element(depth.begin(), depth.end());
}

// Whether a seed at `p` may have the stripe's blurred light in its ring from one side only
// (FindTip's `square`): at least kTipRingEdgeMarginPx inside every side, and kTipCornerReachPx
// from all but the nearest. By a corner the light of two sides reaches the ring and the 3 x 3,
// and the blurred corner of the stripe was taken for a top (a review's probe: 2-7 in 3000
// searches of 10-12 px squares without a top).
bool SeedClearOfTheStripe(const std::array<Eigen::Vector2d, 4>& square, const Eigen::Vector2d& p) {
  std::array<double, 4> depth = SideDepths(square, p);
  std::sort(depth.begin(), depth.end());
  return depth[0] >= kTipRingEdgeMarginPx && depth[1] >= kTipCornerReachPx;
}

// Whether a top below a pixel, seeded at (bx, by), holds the light a white top of radius
// tip_radius_px gives, behind any blur: the sum over the 3 x 3 about the seed above the level
// of the 16 pixels 2 px out (their median) is at least min_contrast x pi r^2 x (white - black),
// and stands kBlurredTopSigmas clear of its own noise, that of the nine pixels and of the
// level, from the largest of: the noise those 16 show (their median absolute deviation), the
// caller's `noise_sigma` (the frame's noise model at the square's black; 0 if not known) and a
// floor. Why
// a sum: a lens spreads the top's light over more pixels and lowers its peak (behind a blur of
// 0.7 px, a top of 0.7 px radius peaks at about a third of what it would), but keeps its total;
// the 3 x 3 holds nine tenths of it up to a blur of 0.8 px. The peak test alone then turns
// away the tops of 10-14 px markers seen through an ordinary camera's optics, and the pose is
// left to the corners, whose two planar solutions are hard to tell apart at that size. The
// median keeps a part of the stripe or a bright bit in a few of the 16 from raising the level.
bool BlurredTopStandsOut(const cv::Mat& img, int bx, int by, double black, double white,
                         double min_contrast, double tip_radius_px, double noise_sigma) {
  if (bx < 2 || by < 2 || bx > img.cols - 3 || by > img.rows - 3) return false;
  std::array<double, 16> ring;
  int n = 0;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx)
      if (std::abs(dx) == 2 || std::abs(dy) == 2) ring[n++] = Grey(img, by + dy, bx + dx);
  auto median = [](std::array<double, 16> v) {
    std::nth_element(v.begin(), v.begin() + 7, v.end());
    const double lo = v[7];
    return 0.5 * (lo + *std::min_element(v.begin() + 8, v.end()));
  };
  const double level = median(ring);
  std::array<double, 16> dev;
  for (int i = 0; i < 16; ++i) dev[i] = std::abs(ring[i] - level);
  // The 16 pixels' median absolute deviation reads the noise 30 % low one time in five, and a
  // flat black patch then passes for a top's light: on flat Gaussian noise, with the seed the
  // brightest pixel of a 3 px search, the noise clause passes one search in 500 on it alone,
  // one in 2 x 10^6 with the frame's noise given. Their standard deviation would err less, but
  // the blurred stripe's light in a small square's ring raises it (a 10 px marker's tops were
  // lost). At least 0.3 % of white - black: a flat black of equal codes shows no spread at all
  // (the rounding of an 8-bit code where the contrast is about 100 codes).
  const double sigma = std::max({1.4826 * median(dev), noise_sigma, 0.003 * (white - black)});
  double sum = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) sum += Grey(img, by + dy, bx + dx) - level;
  // The sum's standard deviation: nine pixels' noise, and nine times the level's, a median of
  // 16 (variance about pi sigma^2 / (2 x 16) for Gaussian noise): 4.1 sigma in all. Pixels
  // whose noise is shared (a demosaic, a JPEG's blocks) make it larger still.
  const double sum_sigma = sigma * std::sqrt(9 + 81 * M_PI / (2 * 16));
  return sum >= min_contrast * M_PI * tip_radius_px * tip_radius_px * (white - black) &&
         sum >= kBlurredTopSigmas * sum_sigma;
}

// A top below a pixel (radius tip_radius_px) seeded at (bx, by): the 3 x 3 around the seed
// hold its light; the ring around them must be dark (a bright ring means the stripe, a bit
// cell or a glint, not an isolated top). Its place is the disc fit's, not the centroid (which
// locks to pixel centres: disc_fit.h).
std::optional<TipObservation> SubPixelTip(const cv::Mat& img, int bx, int by, double black,
                                          double tip_radius_px,
                                          const std::array<Eigen::Vector2d, 4>* square) {
  if (bx < 2 || by < 2 || bx > img.cols - 3 || by > img.rows - 3) return std::nullopt;
  // A seed that near a side may be the stripe's own light, and one near two sides (by a
  // corner) has the stripe's light on two sides of its ring: no exemption there.
  const bool seed_clear = !square || SeedClearOfTheStripe(*square, Eigen::Vector2d(bx, by));
  const double ring_max = black + 0.5 * (Grey(img, by, bx) - black);
  std::array<double, 25> window;
  bool stripe_in_ring = false;  // a ring pixel near a side was bright: fit the 3 x 3 only
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) {
      const double v = Grey(img, by + dy, bx + dx);
      // The ring's four corners (2.8 px out) are not held to it: on an 8 px marker seen
      // 15-20 degrees off-axis the top sits that close to a corner of the white stripe.
      const bool ring = std::abs(dx) == 2 || std::abs(dy) == 2;
      const bool ring_corner = std::abs(dx) == 2 && std::abs(dy) == 2;
      if (ring && !ring_corner && v > ring_max) {
        if (!seed_clear || !square ||
            DepthInSquare(*square, Eigen::Vector2d(bx + dx, by + dy)) >= kTipRingEdgeMarginPx)
          return std::nullopt;
        stripe_in_ring = true;
      }
      window[(dy + 2) * 5 + dx + 2] = v;
    }
  // A top of at most half a pixel centred in the seed lies within its 3 x 3, and the ring is
  // then left out of the fit: on a small marker it may already hold a bit of the stripe.
  std::optional<DiscFit> fit;
  if (tip_radius_px <= 0.5 || stripe_in_ring) {
    std::array<double, 9> inner;
    for (int k = 0; k < 9; ++k) inner[k] = window[(k / 3 + 1) * 5 + k % 3 + 1];
    fit = FitDisc(inner.data(), 3, bx - 1, by - 1, tip_radius_px);
  } else {
    fit = FitDisc(window.data(), 5, bx - 2, by - 2, tip_radius_px);
  }
  if (!fit) return std::nullopt;
  TipObservation t;
  t.pixel = fit->centre;
  // The fit's own sigma, and a floor for what it does not model: the top is an ellipse in
  // an oblique view, and the lens and sensor blur it.
  t.sigma_px = std::hypot(fit->sigma_px, kTipDiscModelSigma);
  return t;
}

// The largest window FloodBlob has flooded on any thread, in pixels.
std::atomic<size_t> largest_flood_window{0};

// Floods the connected pixels of at least local_thr from the seed (bx, by) within window w
// into sc->blob (sc->seen marks them, over the window). False if the blob touches the window's
// edge (inside the image): then it is not a small blob (e.g. the white stripe). *bounds: the
// blob's bounding box.

bool FloodBlob(const cv::Mat& img, const TipWindow& w, int bx, int by, double local_thr,
               PoseScratch* sc, TipWindow* bounds) {
  const int x0 = w.x0, x1 = w.x1, y0 = w.y0, y1 = w.y1;
  std::vector<std::pair<int, int>>&stack = sc->stack, &blob = sc->blob;
  // Every thread's buffers are reserved to the largest window any thread has flooded (blob and
  // seen at most its pixels; the stack the seed and 3 more per pixel marked, which is popped
  // before its 4 neighbours are pushed; FindTip's memo of the blob too): which thread measures
  // which marker changes from frame to frame (DetectorOptions::threads), and buffers grown only
  // by the markers a thread happened to get would still allocate on a later frame of one scene.
  const size_t area = static_cast<size_t>(x1 - x0 + 1) * static_cast<size_t>(y1 - y0 + 1);
  size_t largest = largest_flood_window.load(std::memory_order_relaxed);
  while (area > largest && !largest_flood_window.compare_exchange_weak(largest, area)) {
  }
  largest = std::max(largest, area);
  if (blob.capacity() < largest) blob.reserve(largest);
  if (sc->seen.capacity() < largest) sc->seen.reserve(largest);
  if (stack.capacity() < 3 * largest + 1) stack.reserve(3 * largest + 1);
  stack.assign(1, {bx, by});
  blob.clear();
  std::vector<uint8_t>& seen = sc->seen;
  seen.assign(static_cast<size_t>(x1 - x0 + 1) * (y1 - y0 + 1), 0);
  while (!stack.empty()) {
    auto [x, y] = stack.back();
    stack.pop_back();
    if (x < x0 || x > x1 || y < y0 || y > y1) continue;
    uint8_t& s = seen[(y - y0) * (x1 - x0 + 1) + (x - x0)];
    if (s || Grey(img, y, x) < local_thr) continue;
    s = 1;
    blob.emplace_back(x, y);
    stack.push_back({x + 1, y});
    stack.push_back({x - 1, y});
    stack.push_back({x, y + 1});
    stack.push_back({x, y - 1});
  }
  int bx0 = bx, bx1 = bx, by0 = by, by1 = by;
  for (auto [x, y] : blob) {
    if ((x == x0 && x0 > 0) || (x == x1 && x1 < img.cols - 1) || (y == y0 && y0 > 0) ||
        (y == y1 && y1 < img.rows - 1))
      return false;
    bx0 = std::min(bx0, x);
    bx1 = std::max(bx1, x);
    by0 = std::min(by0, y);
    by1 = std::max(by1, y);
  }
  *bounds = TipWindow{bx0, bx1, by0, by1};
  return true;
}

// The top that FloodBlob found (sc->blob, sc->seen over window w): up to kMaxDiscFitRadiusPx,
// the disc fit on a window about the blob's centroid when nothing else bright is in it; else
// the centroid weighted by brightness, with a sigma that counts its pixel locking.
std::optional<TipObservation> BlobTip(const cv::Mat& img, const TipWindow& w, const PoseScratch& sc,
                                      double black, double local_thr, double tip_radius_px) {
  const int x0 = w.x0, x1 = w.x1, y0 = w.y0, y1 = w.y1;
  const std::vector<std::pair<int, int>>& blob = sc.blob;
  const std::vector<uint8_t>& seen = sc.seen;
  double wsum = 0, w2 = 0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (auto [x, y] : blob) {
    const double wi = Grey(img, y, x) - black;
    c += wi * Eigen::Vector2d(x, y);
    wsum += wi;
  }
  if (wsum <= 0) return std::nullopt;
  c /= wsum;
  if (tip_radius_px <= kMaxDiscFitRadiusPx) {
    // A top of a few pixels: the disc fit on a window about the centroid with a pixel and a
    // half of margin, when nothing else bright is in it (else the centroid, below).
    const int h = static_cast<int>(std::ceil(tip_radius_px + 1.5));
    const int size = 2 * h + 1;
    const int cx = static_cast<int>(std::lround(c.x())), cy = static_cast<int>(std::lround(c.y()));
    bool clear = cx - h >= 0 && cy - h >= 0 && cx + h < img.cols && cy + h < img.rows;
    std::array<double, 256> window;
    for (int dy = -h; clear && dy <= h; ++dy)
      for (int dx = -h; clear && dx <= h; ++dx) {
        const int x = cx + dx, y = cy + dy;
        const double v = Grey(img, y, x);
        const bool in_blob =
            x >= x0 && x <= x1 && y >= y0 && y <= y1 && seen[(y - y0) * (x1 - x0 + 1) + (x - x0)];
        clear = in_blob || v < local_thr;
        window[(dy + h) * size + dx + h] = v;
      }
    if (clear) {
      if (const std::optional<DiscFit> fit =
              FitDisc(window.data(), size, cx - h, cy - h, tip_radius_px, 1.0)) {
        TipObservation t;
        t.pixel = fit->centre;
        t.sigma_px = std::hypot(fit->sigma_px, kTipDiscModelSigma);
        return t;
      }
    }
  }
  for (auto [x, y] : blob) w2 += std::pow(Grey(img, y, x) - black, 2);
  TipObservation t;
  t.pixel = c;
  // Centroid standard error for ~1 grey level of noise, plus a floor for the disc's
  // perspective and the sampling of the blob's edge; for a top of a few pixels at least its
  // pixel locking.
  t.sigma_px = std::sqrt(0.05 * 0.05 + 1.0 / std::max(1.0, w2) * blob.size() * 0.25);
  if (tip_radius_px <= kMaxDiscFitRadiusPx)
    t.sigma_px = std::max(t.sigma_px, kCentroidLockingPxPx / std::max(1.0, tip_radius_px));
  return t;
}

}  // namespace

std::optional<TipObservation> FindTip(const cv::Mat& img, const Eigen::Vector2d& pred,
                                      double radius, double black, double white,
                                      double min_contrast, double tip_radius_px) {
  return FindTip(img, pred, radius, black, white, min_contrast, tip_radius_px, nullptr);
}

std::optional<TipObservation> FindTip(const cv::Mat& img, const Eigen::Vector2d& pred,
                                      double radius, double black, double white,
                                      double min_contrast, double tip_radius_px,
                                      TipSearchMemo* memo,
                                      const std::array<Eigen::Vector2d, 4>* square,
                                      double noise_sigma) {
  const double thr = black + 0.5 * (white - black);
  // The brightest pixel nearest the prediction seeds the blob.
  TipWindow w;
  int bx, by;
  if (!TipSeed(img, pred, radius, black, white, &w, &bx, &by)) return std::nullopt;
  const bool sub_pixel = tip_radius_px < 1;
  const double peak_fraction =
      sub_pixel ? std::min(1.0, 0.5 * M_PI * tip_radius_px * tip_radius_px) : 1.0;
  if (bx < 0) return std::nullopt;
  // A top that stands out by its light only (not its peak) must be ringed by dark all round:
  // by a side, the stripe's blurred light in its 3 x 3 would pass for a top's (FindTip tests).
  const bool by_peak = Grey(img, by, bx) - black >= min_contrast * peak_fraction * (white - black);
  if (!by_peak && !(sub_pixel && BlurredTopStandsOut(img, bx, by, black, white, min_contrast,
                                                     tip_radius_px, noise_sigma)))
    return std::nullopt;
  // The blob's threshold (a top of a pixel or more): halfway to white, or to the seed if that
  // is dimmer.
  const double local_thr = std::min(thr, black + 0.5 * (Grey(img, by, bx) - black));
  // What follows depends, below a pixel, on the seed only; above, on the blob that the seed
  // and threshold flood, and on the window only through whether that blob reaches its edge.
  // So the memo answers for the same seed below a pixel, and above for a seed in its blob with
  // the same threshold when the whole blob lies strictly inside this window (or at the image's
  // border).
  if (memo && MemoAnswers(*memo, img, radius, black, white, min_contrast, tip_radius_px, sub_pixel,
                          w, bx, by, local_thr, square, noise_sigma)) {
    ++memo->reused;
    return memo->tip;
  }
  if (memo)
    StartMemo(memo, img, radius, black, white, min_contrast, tip_radius_px, bx, by, local_thr,
              square, noise_sigma);
  // The answer, kept in the memo: every answer below but a blob's that reaches the window's
  // edge (which depends on the window).
  auto answer = [&](const std::optional<TipObservation>& t) {
    if (memo) {
      memo->valid = true;
      memo->tip = t;
    }
    return t;
  };
  if (sub_pixel)
    return answer(SubPixelTip(img, bx, by, black, tip_radius_px, by_peak ? square : nullptr));
  PoseScratch& sc = Scratch();
  TipWindow bounds;
  if (!FloodBlob(img, w, bx, by, local_thr, &sc, &bounds)) return std::nullopt;
  if (memo) {
    memo->blob_x0 = bounds.x0;
    memo->blob_x1 = bounds.x1;
    memo->blob_y0 = bounds.y0;
    memo->blob_y1 = bounds.y1;
    const size_t largest = largest_flood_window.load(std::memory_order_relaxed);
    if (memo->blob.capacity() < largest) memo->blob.reserve(largest);  // as FloodBlob's
    memo->blob.assign(sc.blob.begin(), sc.blob.end());
  }
  return answer(BlobTip(img, w, sc, black, local_thr, tip_radius_px));
}

Eigen::Vector3d VisibleTipPoint(const MarkerModel& model, const Eigen::Vector3d& cam,
                                double* fraction) {
  const PostModel& post = *model.post;
  const Eigen::Vector3d tip(0, 0, post.height);
  *fraction = 1;
  if (!post.concave()) return tip;
  // A bottom point p is seen if the ray from it to the camera leaves through the opening
  // (radius `radius` at z = 0): |p_xy + s| <= radius with s = |h| (c - p)_xy / (c - p)_z,
  // taken with the ray to the bottom's centre (the well is small against the distance).
  const Eigen::Vector3d v = cam - tip;
  if (v.z() <= 0) {
    *fraction = 0;
    return tip;
  }
  const Eigen::Vector2d shift = -post.height * v.head<2>() / v.z();
  const int n = 24;
  const double r = post.tip_radius;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int inside = 0, visible = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector2d p(r * (2 * (i + 0.5) / n - 1), r * (2 * (j + 0.5) / n - 1));
      if (p.squaredNorm() > r * r) continue;
      ++inside;
      if ((p + shift).squaredNorm() > post.radius * post.radius) continue;
      ++visible;
      sum += p;
    }
  *fraction = inside ? static_cast<double>(visible) / inside : 0;
  if (!visible) return tip;
  const Eigen::Vector2d c = sum / visible;
  return Eigen::Vector3d(c.x(), c.y(), post.height);
}

// Buffers per thread: a warmed-up call allocates nothing.
bool CalibrationCovariance(const CameraModel& camera, const Pose& pose,
                           const std::vector<Eigen::Vector3d>& X, const std::vector<double>& sigma,
                           PoseCovariance* out,
                           const Eigen::Matrix<double, 8, 8>* corner_whitener) {
  const Eigen::MatrixXd& L = camera.intrinsics_covariance_factor();
  if (L.size() == 0) return false;
  thread_local Eigen::Matrix<double, 2, Eigen::Dynamic> dq_dintrinsics;
  thread_local Eigen::MatrixXd G, HG, SL, D8, WD8;
  G.setZero(6, L.rows());
  const bool joint = corner_whitener && X.size() >= 4;
  if (joint) D8.setZero(8, L.rows());
  Eigen::Matrix<double, 8, 6> J8;
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  const Eigen::Matrix3d R = pose.Rotation();
  for (size_t i = 0; i < X.size(); ++i) {
    const Eigen::Vector3d a = R * X[i];
    Eigen::Vector2d q;
    Eigen::Matrix<double, 2, 3> dq_dp;
    if (!camera.Project(a + pose.tvec, &q, &dq_dp, &dq_dintrinsics)) return false;
    // The rows RefinePose uses: [((R X) x g)^T, g^T] for each row g^T of dq/dp.
    Eigen::Matrix<double, 2, 6> J;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d g = dq_dp.row(k).transpose();
      J.block<1, 3>(k, 0) = a.cross(g).transpose();
      J.block<1, 3>(k, 3) = g.transpose();
    }
    if (joint && i < 4) {  // whitened together below, as in RefinePose
      J8.block<2, 6>(2 * i, 0) = J;
      D8.middleRows(2 * i, 2) = dq_dintrinsics;
      continue;
    }
    const double w = 1.0 / (sigma[i] * sigma[i]);
    H.noalias() += w * J.transpose() * J;
    G.noalias() += w * J.transpose() * dq_dintrinsics;
  }
  if (joint) {
    const Eigen::Matrix<double, 8, 6> WJ = *corner_whitener * J8;
    H.noalias() += WJ.transpose() * WJ;
    WD8.noalias() = *corner_whitener * D8;
    G.noalias() += WJ.transpose() * WD8;
  }
  Matrix6d H_inv;
  if (InvertFullPivLu(H, &H_inv) < 6) return false;
  HG.noalias() = H_inv * G;
  SL.noalias() = HG * L;
  out->noalias() = SL * SL.transpose();
  return out->allFinite();
}

bool EdgeResidual(const CameraModel& camera, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const EdgeObservation& e, double* residual, Eigen::Matrix<double, 1, 6>* row) {
  const Eigen::Vector3d a = R * e.point;
  Eigen::Vector2d q;
  Eigen::Matrix<double, 2, 3> dq_dp;
  if (!camera.Project(a + t, &q, &dq_dp)) return false;
  const Eigen::Vector2d along = dq_dp * (R * e.direction);
  if (!(along.norm() > 0)) return false;
  const Eigen::Vector2d n = Eigen::Vector2d(-along.y(), along.x()).normalized();
  *residual = n.dot(q - e.pixel);
  // A row g^T of dq/dp projected on n: [((R X) x g)^T, g^T] (left perturbation).
  const Eigen::Vector3d g = dq_dp.transpose() * n;
  row->head<3>() = a.cross(g).transpose();
  row->tail<3>() = g.transpose();
  return true;
}

bool EdgeQuadratic(const CameraModel& camera, const Pose& cam_from_marker,
                   const std::vector<EdgeObservation>& edges,
                   Eigen::Matrix<double, 6, 6>* information, Eigen::Matrix<double, 6, 1>* offset) {
  const Eigen::Matrix3d R = cam_from_marker.Rotation();
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  for (const EdgeObservation& e : edges) {
    double r;
    Eigen::Matrix<double, 1, 6> row;
    if (!EdgeResidual(camera, R, cam_from_marker.tvec, e, &r, &row)) return false;
    AddRow(row.head<3>().transpose(), row.tail<3>().transpose(), 1.0 / (e.sigma_px * e.sigma_px), r,
           &H, &g);
  }
  H.triangularView<Eigen::StrictlyLower>() = H.transpose();
  Matrix6d vectors;
  const Vector6d values = SymmetricEigenvalues(H, &vectors);
  const double floor = 1e-12 * std::max(0.0, values.maxCoeff());
  Vector6d inverse = Vector6d::Zero();
  for (int k = 0; k < 6; ++k)
    if (values(k) > floor && floor > 0) inverse(k) = 1 / values(k);
  *information = H;
  *offset = -(vectors * inverse.asDiagonal() * vectors.transpose() * g);
  return information->allFinite() && offset->allFinite();
}

bool RefinePose(const CameraModel& camera, const std::vector<Eigen::Vector3d>& X,
                const std::vector<Eigen::Vector2d>& px, const std::vector<double>& sigma,
                Pose* pose, PoseCovariance* cov, double* rms,
                const std::vector<EdgeObservation>* edges, int max_iterations,
                const Eigen::Matrix<double, 8, 8>* corner_whitener) {
  Eigen::Matrix3d R = pose->Rotation();
  Eigen::Vector3d t = pose->tvec;
  Eigen::Matrix<double, 6, 6> JtWJ;
  const bool joint = corner_whitener && X.size() >= 4;
  Eigen::Matrix<double, 8, 6> J8;
  Eigen::Matrix<double, 8, 1> r8;
  for (int iter = 0; iter < max_iterations; ++iter) {
    JtWJ.setZero();
    Eigen::Matrix<double, 6, 1> JtWr = Eigen::Matrix<double, 6, 1>::Zero();
    double ss = 0;
    for (size_t i = 0; i < X.size(); ++i) {
      const Eigen::Vector3d p = R * X[i] + t;
      Eigen::Vector2d q;
      Eigen::Matrix<double, 2, 3> dq_dp;
      if (!camera.Project(p, &q, &dq_dp)) return false;
      const Eigen::Vector2d r = q - px[i];
      ss += r.squaredNorm();
      // Left perturbation in camera axes: p = exp([d]) R X + t  ->  dp/dd = -[R X]x, dp/dt = I;
      // a row g^T of dq/dp gives the row [((R X) x g)^T, g^T].
      const Eigen::Vector3d a = R * X[i];
      if (joint && i < 4) {  // whitened together below
        for (int k = 0; k < 2; ++k) {
          J8.block<1, 3>(2 * i + k, 0) = a.cross(dq_dp.row(k).transpose()).transpose();
          J8.block<1, 3>(2 * i + k, 3) = dq_dp.row(k);
        }
        r8.segment<2>(2 * i) = r;
        continue;
      }
      const double w = 1.0 / (sigma[i] * sigma[i]);
      for (int k = 0; k < 2; ++k)
        AddRow(a.cross(dq_dp.row(k).transpose()), dq_dp.row(k).transpose(), w, r[k], &JtWJ, &JtWr);
    }
    if (joint) {
      const Eigen::Matrix<double, 8, 6> WJ = *corner_whitener * J8;
      const Eigen::Matrix<double, 8, 1> Wr = *corner_whitener * r8;
      for (int k = 0; k < 8; ++k)
        AddRow(WJ.block<1, 3>(k, 0).transpose(), WJ.block<1, 3>(k, 3).transpose(), 1, Wr(k), &JtWJ,
               &JtWr);
    }
    // Edge points: the distance across the edge's image (EdgeResidual).
    for (size_t i = 0; edges && i < edges->size(); ++i) {
      const EdgeObservation& e = (*edges)[i];
      double r;
      Eigen::Matrix<double, 1, 6> row;
      if (!EdgeResidual(camera, R, t, e, &r, &row)) return false;
      AddRow(row.head<3>().transpose(), row.tail<3>().transpose(), 1.0 / (e.sigma_px * e.sigma_px),
             r, &JtWJ, &JtWr);
    }
    JtWJ.triangularView<Eigen::StrictlyLower>() = JtWJ.transpose();
    const PoseStep step = PoseGaussNewtonStep(JtWJ, JtWr, kMarkerPoseTolerances, &R, &t);
    if (step == PoseStep::kFailed) return false;
    *rms = std::sqrt(ss / X.size());
    if (step == PoseStep::kConverged) break;
  }
  *pose = Pose::FromRotation(R, t);
  if (InvertFullPivLu(JtWJ, cov) < 6) return false;
  return cov->allFinite();
}

namespace {

// Two straight edges of the print that the decoded ID locates, found in the image around
// `pose` and added to the fit over X (corners and tip), which is then redone:
//  0. the white stripe's outer edge (half-side 5 cells) where a black bit cell borders it;
//  1. the decal's outer edge (half-side 6 cells) where a white bit cell meets a darker skin
//     (only found where the skin is darker: on a white page there is no such edge).
// Their leverage on the orientation is 5/3 and 2 times the black square's. Each group's
// sigma is its own scatter about the fitted edges (at least 0.03 px) times sqrt(3) for the
// three correlated points per cell; points beyond 3 sigmas (at least 0.3 px) are dropped
// once, as an occluder or a glint at a cell would place them. A group with fewer than 12
// points on 3 sides is left out. Leaves *pose and *cov as they were when the cells are too
// small, no group has enough points, or a fit fails. Returns the number of edge points in the
// fit (0 when *pose and *cov were left as they were), and their own quadratic at the new pose
// in *information and *offset (EdgeQuadratic; untouched when 0 is returned).
int RefineWithStripeEdge(const cv::Mat& image, const MarkerModel& model, const CameraModel& camera,
                         const MarkerPoseOptions& o, const std::vector<Eigen::Vector3d>& X,
                         const std::vector<Eigen::Vector2d>& px, const std::vector<double>& sig,
                         const Eigen::Matrix<double, 8, 8>* corner_whitener, Pose* pose,
                         PoseCovariance* cov, Eigen::Matrix<double, 6, 6>* information,
                         Eigen::Matrix<double, 6, 1>* offset) {
  if (!o.use_stripe_edge || !(model.cell_size > 0) || model.id < 0) return 0;
  thread_local std::vector<EdgeObservation> edges;
  thread_local std::vector<int> group;
  edges.clear();
  group.clear();
  const uint64_t code = Svms44::Codeword(model.id);
  const double c = model.cell_size;
  const Eigen::Matrix3d R = pose->Rotation();
  std::array<std::array<int, 4>, 2> per_side{};
  for (int i = 0; i < 44; ++i) {
    const int g = ((code >> i) & 1) ? 1 : 0;  // white cell: the decal's edge; black: the stripe's
    if (g == 1 && !o.use_decal_edge) continue;
    const double h = g == 0 ? 5 * c : 6 * c;  // the edge's half-side
    const Eigen::Vector2d cc = model.BitCellCentre(i);
    const bool on_x = std::abs(std::abs(cc.x()) - 5.5 * c) < 0.1 * c;  // left or right column
    const bool on_y = std::abs(std::abs(cc.y()) - 5.5 * c) < 0.1 * c;  // top or bottom row
    if (on_x == on_y) continue;  // a corner cell: its edges run two ways
    // Along the edge (marker frame), and toward the centre: dark -> bright across either edge
    // (black cell -> white stripe; dark skin -> white cell).
    const Eigen::Vector3d along = on_y ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d inward = on_y ? Eigen::Vector3d(0, cc.y() > 0 ? -1 : 1, 0)
                                        : Eigen::Vector3d(cc.x() > 0 ? -1 : 1, 0, 0);
    const int side = on_y ? (cc.y() > 0 ? 0 : 2) : (cc.x() > 0 ? 1 : 3);
    // Three points per cell. They share much of their error (below), but not all: with two,
    // the orientation error at 16 m (30 px) is 0.82 degrees against 0.69 with three.
    for (double f : {-0.25, 0.0, 0.25}) {
      const Eigen::Vector3d P = (on_y ? Eigen::Vector3d(cc.x() + f * c, cc.y() > 0 ? h : -h, 0)
                                      : Eigen::Vector3d(cc.x() > 0 ? h : -h, cc.y() + f * c, 0));
      const Eigen::Vector3d P_cam = R * P + pose->tvec;
      Eigen::Vector2d q0, q1, q2;
      if (!camera.Project(P_cam, &q0) || !camera.Project(P_cam + 0.5 * c * (R * inward), &q1) ||
          !camera.Project(P_cam + 0.5 * c * (R * along), &q2))
        return 0;
      const double cell_px = 2 * std::min((q1 - q0).norm(), (q2 - q0).norm());
      if (cell_px < o.stripe_edge_min_cell_px) return 0;
      // The search stays within the cell and its neighbour across the edge (0.4 cell either way).
      Eigen::Vector2d edge;
      double strength;
      if (!LocateEdge(image, q0, (q1 - q0).normalized(), std::min(2.5, 0.4 * cell_px), &edge,
                      &strength))
        continue;
      edges.push_back({P, along, edge, 0.1});
      group.push_back(g);
      ++per_side[g][side];
    }
  }
  std::array<bool, 2> usable{};
  for (int g = 0; g < 2; ++g) {
    int sides = 0, n = 0;
    for (int k : per_side[g]) {
      sides += k >= 2;
      n += k;
    }
    usable[g] = n >= 12 && sides >= 3;
  }
  auto keep_usable = [&] {
    size_t kept = 0;
    for (size_t i = 0; i < edges.size(); ++i) {
      if (!usable[group[i]]) continue;
      edges[kept] = edges[i];
      group[kept++] = group[i];
    }
    edges.resize(kept);
    group.resize(kept);
  };
  keep_usable();
  if (edges.empty()) return 0;
  Pose p = *pose;
  PoseCovariance C;
  double rms;
  // First fit at a nominal 0.1 px, then each group's own scatter sets its sigma. Its pose
  // serves only to measure that scatter: three iterations from the corners' pose suffice.
  if (!RefinePose(camera, X, px, sig, &p, &C, &rms, &edges, 3, corner_whitener)) return 0;
  thread_local std::vector<double> residual;
  residual.clear();
  std::array<double, 2> ss{};
  std::array<int, 2> count{};
  const Eigen::Matrix3d R_fit = p.Rotation();
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeObservation& e = edges[i];
    const Eigen::Vector3d e_cam = R_fit * e.point + p.tvec;
    Eigen::Vector2d q, q2;
    if (!camera.Project(e_cam, &q) || !camera.Project(e_cam + 1e-3 * (R_fit * e.direction), &q2))
      return 0;
    const Eigen::Vector2d along = q2 - q;
    residual.push_back(Eigen::Vector2d(-along.y(), along.x()).normalized().dot(q - e.pixel));
    ss[group[i]] += residual.back() * residual.back();
    ++count[group[i]];
  }
  // Each group's own scatter (the pose takes few dof of so many points), times sqrt(3): the
  // three points along one cell's edge lie within a cell of each other, closer than the edge
  // locator's 4 px profile, and share their error (blur, pixel phase, the cell's own far
  // edge); the independent measurements are the cells.
  std::array<double, 2> sigma{}, cut{};
  for (int g = 0; g < 2; ++g) {
    sigma[g] = std::max(0.03, std::sqrt(ss[g] / std::max(1, count[g]))) * std::sqrt(3.0);
    cut[g] = std::max(3 * sigma[g], 0.3);
  }
  std::array<int, 2> kept_in{};
  size_t kept = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    const int g = group[i];
    if (std::abs(residual[i]) > cut[g]) continue;
    edges[kept] = edges[i];
    edges[kept].sigma_px = sigma[g];
    group[kept++] = g;
    ++kept_in[g];
  }
  edges.resize(kept);
  group.resize(kept);
  for (int g = 0; g < 2; ++g) usable[g] = usable[g] && kept_in[g] >= 12;
  keep_usable();
  if (edges.empty()) return 0;
  if (!RefinePose(camera, X, px, sig, &p, &C, &rms, &edges, 10, corner_whitener)) return 0;
  if (!EdgeQuadratic(camera, p, edges, information, offset)) return 0;
  *pose = p;
  *cov = C;
  return static_cast<int>(edges.size());
}

// A planar solution of the corners, with the white top found where it predicts the tip.
struct TipCandidate {
  Pose pose;
  std::optional<TipObservation> tip;
  double tip_error = 1e300;  // pixels between the top found and the prediction
};
// At most two candidates, in a fixed array (no allocation per frame).
struct TipCandidates {
  std::array<TipCandidate, 2> c;
  size_t n = 0;
  size_t size() const { return n; }
  bool empty() const { return n == 0; }
  void push_back(const TipCandidate& x) { c[n++] = x; }
  const TipCandidate& operator[](size_t i) const { return c[i]; }
};
// A candidate refined over the corners (and the tip).
struct RefinedCandidate {
  Pose pose;
  PoseCovariance covariance = PoseCovariance::Zero();
  double chi2 = 1e300, rms = 0;  // weighted squared residuals; RMS residual, pixels
  bool ok = false;
};

// Both planar solutions of the corners (IPPE, as OpenCV's SOLVEPNP_IPPE_SQUARE; ippe.h), from
// the corners on the z = 1 plane. False (and *failure) if a corner does not unproject in
// front of the camera or the quadrilateral is degenerate.
bool PlanarSolutions(const std::array<Eigen::Vector2d, 4>& corners, const MarkerModel& model,
                     const CameraModel& camera, std::array<PlanarPoseCandidate, 2>* ippe,
                     std::string* failure) {
  std::array<Eigen::Vector2d, 4> normalized;
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector3d d;
    if (!camera.Unproject(corners[k], &d) || d.z() <= 0) {
      *failure = "corner " + std::to_string(k) +
                 " does not unproject to a direction in front "
                 "of the camera";
      return false;
    }
    normalized[k] = d.head<2>() / d.z();
  }
  if (!SolveSquareIppe(normalized, model.size, ippe)) {
    *failure = "the corners give no planar pose (degenerate quadrilateral)";
    return false;
  }
  return true;
}

// The planar solutions in front of the camera, each with the white top searched for where it
// puts the tip (FindTip, sharing one memo: the two usually find the same top). The tip is
// looked for only where it can be told from the marker's own print: a white top of at least
// tip_min_radius_px, searched no farther than 60 % of the way to the edge of the innermost
// black square (a dual's inner stripe and bits lie beyond it).
void FindCandidateTips(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& corners,
                       const MarkerModel& model, const CameraModel& camera, double black,
                       double white, const MarkerPoseOptions& o,
                       const std::array<PlanarPoseCandidate, 2>& ippe, TipCandidates* cands) {
  const double side_px =
      0.25 * ((corners[1] - corners[0]).norm() + (corners[2] - corners[1]).norm() +
              (corners[3] - corners[2]).norm() + (corners[0] - corners[3]).norm());
  // The candidates usually find the same top (kept per thread: its blob's buffer is reused).
  TipSearchMemo& tip_memo = Scratch().tip_memo;
  tip_memo.valid = false;
  tip_memo.reused = 0;
  for (const PlanarPoseCandidate& solution : ippe) {
    TipCandidate c;
    c.pose = Pose::FromRotation(solution.cam_from_marker_R, solution.cam_from_marker_t);
    if (c.pose.tvec.z() <= 0) continue;
    const double px_per_m = side_px / model.size;
    const double innermost_half = 0.5 * (model.inner ? model.inner->size : model.size) * px_per_m;
    const double search = std::min(o.tip_search_fraction * side_px, 0.6 * innermost_half);
    if (model.post && model.post->tip_radius * px_per_m >= o.tip_min_radius_px && search >= 1.5) {
      double fraction;
      const Eigen::Vector3d tip3 = VisibleTipPoint(model, c.pose.Inverse().tvec, &fraction);
      Eigen::Vector2d pred;
      if (fraction >= 0.25 && camera.Project(c.pose * tip3, &pred)) {
        c.tip =
            FindTip(image, pred, search, black, white, o.tip_min_contrast,
                    model.post->tip_radius * px_per_m, &tip_memo, &corners, o.black_noise_sigma);
        if (c.tip) c.tip_error = (c.tip->pixel - pred).norm();
      }
    }
    cands->push_back(c);
  }
}

// The points a candidate at `pose` is fitted over (marker frame), their pixels and sigmas: the
// four corners (each corner_fit_scale x its line-fit sigma, at least min_corner_sigma_px; or
// corner_sigma_px where that is not known) and, with `tip`, the part of the white top the
// camera sees.
void FitPoints(const std::array<Eigen::Vector2d, 4>& corners, const MarkerModel& model,
               const CameraModel& camera, const MarkerPoseOptions& o,
               const std::array<double, 4>& corner_sigma, const Pose& pose,
               const TipObservation* tip, std::vector<Eigen::Vector3d>* X,
               std::vector<Eigen::Vector2d>* px, std::vector<double>* sig) {
  X->clear();
  px->clear();
  sig->clear();
  for (int k = 0; k < 4; ++k) {
    X->push_back(model.Corners()[k]);
    px->push_back(corners[k]);
    sig->push_back(corner_sigma[k] > 0
                       ? std::max(o.min_corner_sigma_px, o.corner_fit_scale * corner_sigma[k])
                       : o.corner_sigma_px);
  }
  if (!tip) return;
  double fraction = 1;
  X->push_back(VisibleTipPoint(model, pose.Inverse().tvec, &fraction));
  px->push_back(tip->pixel);
  double sigma = tip->sigma_px;
  if (model.post->concave()) {
    // What is bright at the bottom of a well is what is both seen and lit; the detector
    // does not know where the light comes from, so the observation is only good to about
    // half the bore's image: enough to choose the planar solution, little weight in the
    // refinement.
    Eigen::Vector2d c0, c1;
    if (camera.Project(pose * Eigen::Vector3d(0, 0, 0), &c0) &&
        camera.Project(pose * Eigen::Vector3d(model.post->radius, 0, 0), &c1))
      sigma = std::max(sigma, 0.5 * (c1 - c0).norm());
  }
  sig->push_back(sigma);
}

// Where o.corner_covariance_from_fit and the detector gave the corners' joint covariance
// (RefinedCorners::corner_covariance, nonzero): in *storage the whitener W of C =
// corner_covariance_scale^2 x that covariance, each corner's 2 x 2 block raised where its mean
// variance is below min_corner_sigma_px^2; W = L^-1 for C = L L^T, so W C W^T = I. nullptr
// otherwise: the corners are independent, with FitPoints' sigmas.
const Eigen::Matrix<double, 8, 8>* CornerWhitener(const MarkerPoseOptions& o,
                                                  const std::array<double, 4>& corner_sigma,
                                                  const Eigen::Matrix<double, 8, 8>* covariance,
                                                  Eigen::Matrix<double, 8, 8>* storage) {
  if (!o.corner_covariance_from_fit || !covariance || !(covariance->diagonal().minCoeff() > 0))
    return nullptr;
  Eigen::Matrix<double, 8, 8> C =
      o.corner_covariance_scale * o.corner_covariance_scale * *covariance;
  for (int k = 0; k < 4; ++k) {
    const double floor2 = o.min_corner_sigma_px * o.min_corner_sigma_px;
    const double own = 0.5 * C.block<2, 2>(2 * k, 2 * k).trace();
    if (!(corner_sigma[k] > 0) || !(own > 0)) return nullptr;
    if (own < floor2) C.block<2, 2>(2 * k, 2 * k) += (floor2 - own) * Eigen::Matrix2d::Identity();
  }
  const Eigen::LLT<Eigen::Matrix<double, 8, 8>> llt(C);
  if (llt.info() != Eigen::Success) return nullptr;
  *storage = llt.matrixL().solve(Eigen::Matrix<double, 8, 8>::Identity());
  return storage->allFinite() ? storage : nullptr;
}

// Refines f->pose over X (RefinePose) and weighs the result (f->chi2, f->ok). With a well's
// tip (`well_tip`), whose visible bottom depends on the pose, once more with the refined one.
void RefineCandidate(const CameraModel& camera, const MarkerModel& model, bool well_tip,
                     std::vector<Eigen::Vector3d>* X, const std::vector<Eigen::Vector2d>& px,
                     const std::vector<double>& sig,
                     const Eigen::Matrix<double, 8, 8>* corner_whitener, RefinedCandidate* f) {
  if (!RefinePose(camera, *X, px, sig, &f->pose, &f->covariance, &f->rms, nullptr, 10,
                  corner_whitener))
    return;
  if (well_tip) {
    double fraction = 1;
    X->back() = VisibleTipPoint(model, f->pose.Inverse().tvec, &fraction);
    if (!RefinePose(camera, *X, px, sig, &f->pose, &f->covariance, &f->rms, nullptr, 10,
                    corner_whitener))
      return;
  }
  f->chi2 = WeightedSquaredResiduals(camera, *X, px, sig, f->pose, corner_whitener);
  f->ok = std::isfinite(f->chi2);
}

// Every candidate refined over the corners (and the tip), into refined[0..cands.size()), and
// the one whose weighted squared residuals are least (*pick): unlike the tip's distance from
// each prediction alone, this weighs the tip against the corners by their sigmas, and two
// candidates that the tip pulls to the same pose (a nearly head-on view) count as one. A tip
// that the kept pose cannot explain (a reflection, a bright speck) is dropped (*use_tip
// false) and the candidates weighed again on their corners alone. X, px and sig are left
// holding the last candidate's points. False (and *failure) if no refinement converged.
bool ChooseCandidate(const std::array<Eigen::Vector2d, 4>& corners, const MarkerModel& model,
                     const CameraModel& camera, const MarkerPoseOptions& o,
                     const std::array<double, 4>& corner_sigma,
                     const Eigen::Matrix<double, 8, 8>* corner_whitener, const TipCandidates& cands,
                     const std::optional<TipObservation>& tip, std::vector<Eigen::Vector3d>* X,
                     std::vector<Eigen::Vector2d>* px, std::vector<double>* sig,
                     std::array<RefinedCandidate, 2>* refined, size_t* pick_out, bool* use_tip,
                     std::string* failure) {
  size_t pick = 0;
  *use_tip = tip.has_value();
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t s = 0; s < cands.size(); ++s) {
      RefinedCandidate& f = (*refined)[s];
      f = RefinedCandidate();
      f.pose = cands[s].pose;
      FitPoints(corners, model, camera, o, corner_sigma, f.pose, *use_tip ? &*tip : nullptr, X, px,
                sig);
      RefineCandidate(camera, model, *use_tip && model.post->concave(), X, *px, *sig,
                      corner_whitener, &f);
      if (f.ok && (!(*refined)[pick].ok || s == 0 || f.chi2 < (*refined)[pick].chi2)) pick = s;
    }
    if (!(*refined)[pick].ok) {
      *failure = "the pose refinement over the corners did not converge";
      return false;
    }
    if (!*use_tip) break;
    double fraction = 1;
    Eigen::Vector2d pred;
    const Eigen::Vector3d tip3 =
        VisibleTipPoint(model, (*refined)[pick].pose.Inverse().tvec, &fraction);
    if (camera.Project((*refined)[pick].pose * tip3, &pred) &&
        (pred - tip->pixel).norm() <= 4 * sig->back() + 1.0)
      break;
    *use_tip = false;
    pick = 0;
  }
  *pick_out = pick;
  return true;
}

// The other candidate (b; the kept one a), when it is a distinct pose and not much less
// likely, is what the covariance must also cover: the two as a mixture weighted by their
// likelihoods, about the kept one, (1 - w) C + w (C' + d d^T) with w = 1 / (1 + exp(dchi2 /
// 2)), added to out->covariance. Flagged ambiguous when w is above 1 % (dchi2 below 9.2). Both
// are as refined over the same points (the edges, fitted to the kept one only, would set the
// two apart when they are one). True if the two are distinct (their likelihoods weighed).
bool WidenForOtherCandidate(const RefinedCandidate& a, const RefinedCandidate& b, MarkerPose* out) {
  Eigen::Matrix<double, 6, 1> d;
  const Eigen::AngleAxisd delta(b.pose.Rotation() * a.pose.Rotation().transpose());
  d << delta.angle() * delta.axis(), b.pose.tvec - a.pose.tvec;
  // a.covariance^-1 d. Whether the covariance is positive is not asked: the LDLT's solution is
  // what the separation below is measured with either way.
  Vector6d information_d;
  SolveLdlt(a.covariance, d, &information_d);
  const double separation = d.dot(information_d);
  const double dchi2 = std::max(0.0, b.chi2 - a.chi2);
  if (separation > 9 && dchi2 < 2 * std::log(1 / kMixtureWeightFloor - 1)) {
    const double w = 1 / (1 + std::exp(0.5 * dchi2));
    out->ambiguity_covariance = w * (b.covariance - out->covariance + d * d.transpose());
    out->covariance += out->ambiguity_covariance;
    out->ambiguous = w > kAmbiguousWeight && delta.angle() > kAmbiguousMinDeg * M_PI / 180;
    if (out->ambiguous) {
      out->alternative = b.pose;
      out->alternative_weight = w;
    }
  }
  return separation > 9;
}

// Where no distinct second solution survived the refinement (both slid to one minimum: on a
// marker of 8-10 px a corner 3 sigmas off outweighs a tip 1 sigma off), the kept pose's planar
// twin is what the data may still have confused it with. How far apart the two put the
// points X (pixel sigmas sig), in sigmas (D = sum |twin - kept|^2 / sigma^2, the expected
// difference of their weighted squared residuals), says how often noise alone would swap
// them: Phi(-sqrt(D) / 2). The covariance spans the twin with that weight; above 1 % (and
// kAmbiguousMinDeg) the pose is flagged ambiguous.
void WidenForPlanarTwin(const CameraModel& camera, const Pose& pose,
                        const std::vector<Eigen::Vector3d>& X, const std::vector<double>& sig,
                        const Eigen::Matrix<double, 8, 8>* corner_whitener, MarkerPose* out) {
  const Pose twin = PlanarTwin(pose);
  Eigen::Matrix<double, 6, 1> d;
  const Eigen::AngleAxisd delta(twin.Rotation() * pose.Rotation().transpose());
  d << delta.angle() * delta.axis(), Eigen::Vector3d::Zero();
  Vector6d information_d;  // out->covariance^-1 d, as in WidenForOtherCandidate
  SolveLdlt(out->covariance, d, &information_d);
  const double separation = d.dot(information_d);
  double D = 0;
  bool projected = true;
  const bool joint = corner_whitener && X.size() >= 4;
  Eigen::Matrix<double, 8, 1> d8;
  for (size_t i = 0; i < X.size() && projected; ++i) {
    Eigen::Vector2d p_kept, p_twin;
    projected = camera.Project(pose * X[i], &p_kept) && camera.Project(twin * X[i], &p_twin);
    if (joint && i < 4)
      d8.segment<2>(2 * i) = p_twin - p_kept;
    else
      D += (p_twin - p_kept).squaredNorm() / (sig[i] * sig[i]);
  }
  if (joint && projected) D += (*corner_whitener * d8).squaredNorm();
  const double w = 0.5 * std::erfc(std::sqrt(D) / 2 / std::sqrt(2.0));
  if (projected && separation > 9 && w > kMixtureWeightFloor) {
    out->ambiguity_covariance = w * d * d.transpose();
    out->covariance += out->ambiguity_covariance;
    out->ambiguous = w > kAmbiguousWeight && delta.angle() > kAmbiguousMinDeg * M_PI / 180;
    if (out->ambiguous) {
      out->alternative = twin;
      out->alternative_weight = w;
    }
  }
}

}  // namespace

bool EstimateMarkerPose(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& corners,
                        const MarkerModel& model, const CameraModel& camera, double black,
                        double white, const MarkerPoseOptions& o, MarkerPose* out,
                        const std::array<double, 4>& corner_sigma,
                        const Eigen::Matrix<double, 8, 8>* corner_covariance) {
  // Both planar solutions, and the tip where each puts it.
  std::array<PlanarPoseCandidate, 2> ippe;
  if (!PlanarSolutions(corners, model, camera, &ippe, &out->failure)) return false;
  TipCandidates cands;
  FindCandidateTips(image, corners, model, camera, black, white, o, ippe, &cands);
  if (cands.empty()) {
    out->failure = "both planar poses put the marker behind the camera";
    return false;
  }
  out->solutions = static_cast<int>(cands.size());
  // The tip observation: the white top found nearest its candidate's prediction.
  size_t tip_from = 0;
  for (size_t s = 1; s < cands.size(); ++s)
    if (cands[s].tip_error < cands[tip_from].tip_error) tip_from = s;
  const std::optional<TipObservation> tip = cands[tip_from].tip;
  // Every candidate refined over the corners (and the tip); the best one kept.
  PoseScratch& sc = Scratch();
  std::vector<Eigen::Vector3d>& X = sc.X;
  std::vector<Eigen::Vector2d>& px = sc.px;
  std::vector<double>& sig = sc.sigma;
  const Eigen::Matrix<double, 8, 8>* whitener =
      CornerWhitener(o, corner_sigma, corner_covariance, &sc.corner_whitener);
  out->joint_corners = whitener != nullptr;
  std::array<RefinedCandidate, 2> refined;
  size_t pick = 0;
  bool use_tip = false;
  if (!ChooseCandidate(corners, model, camera, o, corner_sigma, whitener, cands, tip, &X, &px, &sig,
                       &refined, &pick, &use_tip, &out->failure))
    return false;
  // X, px and sig hold the last candidate's points; the kept one's differ only in a well's
  // visible bottom, which follows the pose.
  if (use_tip) {
    double fraction = 1;
    X.back() = VisibleTipPoint(model, refined[pick].pose.Inverse().tvec, &fraction);
  }
  Pose pose = refined[pick].pose;
  out->covariance = refined[pick].covariance;
  out->rms_px = refined[pick].rms;
  out->edge_information.setZero();
  out->edge_offset.setZero();
  out->edge_points =
      RefineWithStripeEdge(image, model, camera, o, X, px, sig, whitener, &pose, &out->covariance,
                           &out->edge_information, &out->edge_offset);
  // The other planar solution, as far as the data leave it likely, widens the covariance.
  out->ambiguous = false;
  out->ambiguity_covariance.setZero();
  out->alternative.reset();
  out->alternative_weight = 0;
  bool weighed = false;  // the other solution's likelihood is known
  const size_t other = 1 - pick;
  if (cands.size() > 1 && refined[other].ok)
    weighed = WidenForOtherCandidate(refined[pick], refined[other], out);
  if (!weighed) WidenForPlanarTwin(camera, pose, X, sig, whitener, out);
  out->calibration_in_covariance = false;
  if (o.use_calibration_covariance && camera.intrinsics_covariance_factor().size() > 0) {
    PoseCovariance calibration;
    if (CalibrationCovariance(camera, pose, X, sig, &calibration, whitener)) {
      out->covariance += calibration;
      out->calibration_in_covariance = true;
    }
  }
  out->cam_from_marker = pose;
  out->tip = use_tip ? tip : std::nullopt;
  return true;
}

std::optional<ExcludedRegion> PostSilhouette(const MarkerModel& model, const CameraModel& camera,
                                             const Pose& cam_from_marker, double margin_px) {
  if (!model.post || model.post->concave()) return std::nullopt;
  const Eigen::Vector3d base = cam_from_marker * Eigen::Vector3d::Zero();
  const Eigen::Vector3d top = cam_from_marker * Eigen::Vector3d(0, 0, model.post->height);
  const double r = std::max(model.post->radius, model.post->tip_radius);
  ExcludedRegion region;
  Eigen::Vector2d px, py;
  if (!camera.Project(base, &region.a) || !camera.Project(top, &region.b) ||
      !camera.Project(top + Eigen::Vector3d(r, 0, 0), &px) ||
      !camera.Project(top + Eigen::Vector3d(0, r, 0), &py))
    return std::nullopt;
  region.radius = std::max((px - region.b).norm(), (py - region.b).norm()) + margin_px;
  return region;
}

namespace {
double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm();
}
double Cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}
}  // namespace

bool RegionTouchesSides(const ExcludedRegion& region,
                        const std::array<Eigen::Vector2d, 4>& corners) {
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d &p = corners[k], &q = corners[(k + 1) % 4];
    const Eigen::Vector2d &a = region.a, &b = region.b;
    // Proper crossing of the two segments, else the nearest end point.
    const double d1 = Cross(q - p, a - p), d2 = Cross(q - p, b - p);
    const double d3 = Cross(b - a, p - a), d4 = Cross(b - a, q - a);
    if (d1 * d2 < 0 && d3 * d4 < 0) return true;
    const double d = std::min({PointSegmentDistance(a, p, q), PointSegmentDistance(b, p, q),
                               PointSegmentDistance(p, a, b), PointSegmentDistance(q, a, b)});
    if (d < region.radius) return true;
  }
  return false;
}

}  // namespace svms
