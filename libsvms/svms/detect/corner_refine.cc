#include "svms/detect/corner_refine.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "svms/base/statistics.h"
#include "svms/base/thread_scratch.h"
#include "svms/detect/codec_blocks.h"

namespace svms {

namespace {

// Bilinear samples of one 8- or 16-bit image: the row pointer and depth resolved once, the
// clamping only near the border (RefineCorners takes about 10^4 samples per marker).
class Sampler {
 public:
  explicit Sampler(const cv::Mat& img)
      : img_(img), wide_(img.depth() == CV_16U), max_u_(img.cols - 1.0), max_v_(img.rows - 1.0) {}
  double operator()(double u, double v) const {
    if (!(u >= 0 && v >= 0 && u < max_u_ - 1e-9 && v < max_v_ - 1e-9)) return Clamped(u, v);
    const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
    const double fx = u - x0, fy = v - y0;
    return wide_ ? Blend<uint16_t>(x0, y0, fx, fy) : Blend<uint8_t>(x0, y0, fx, fy);
  }

 private:
  template <typename T>
  double Blend(int x0, int y0, double fx, double fy) const {
    const T* r0 = img_.ptr<T>(y0) + x0;
    const T* r1 = img_.ptr<T>(y0 + 1) + x0;
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  }
  double Clamped(double u, double v) const {
    u = std::clamp(std::isnan(u) ? 0.0 : u, 0.0, max_u_);
    v = std::clamp(std::isnan(v) ? 0.0 : v, 0.0, max_v_);
    const int x0 = std::min(static_cast<int>(u), std::max(img_.cols - 2, 0));
    const int y0 = std::min(static_cast<int>(v), std::max(img_.rows - 2, 0));
    const int x1 = std::min(x0 + 1, img_.cols - 1), y1 = std::min(y0 + 1, img_.rows - 1);
    const double fx = u - x0, fy = v - y0;
    auto at = [&](int y, int x) -> double {
      return wide_ ? img_.at<uint16_t>(y, x) : img_.at<uint8_t>(y, x);
    };
    return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x1)) +
           fy * ((1 - fx) * at(y1, x0) + fx * at(y1, x1));
  }
  const cv::Mat& img_;
  const bool wide_;
  const double max_u_, max_v_;
};

// The widest window AreaAlongPixelRow takes (half-width across the edge, pixels): what its
// buffer holds at 45 degrees. The narrowest, on sharp edges: the +-2 px of LocateEdgeWith's
// profile.
constexpr double kMaxRowWindowPx = 4.0, kMinRowWindowPx = 2.0;

// The edge through `centre` (pixels; within a few tenths of a pixel of the edge) across which
// the intensity rises along `outward`, from the pixels' own values along the pixel row (or
// column) through it: the one of the two axes nearer `outward`, the centre first moved along
// the edge onto that row. The window and its levels are those of the profile along the normal
// (W either side across the edge, each level the mean over the outer 0.5 px), which along the
// row are 1 / cos(angle to the axis) longer. The integral of the values' linear interpolant
// along a row is exact for a straight edge seen through square pixels (and any symmetric blur),
// whatever the edge's angle and pixel phase: the bright length it gives is the edge's place on
// the row. Why not the area along the normal alone: a profile sampled bilinearly across pixels
// at an angle is not the pixels' profile, and its area moves with the pixel phase. On 60 px
// markers without sensor noise (24 views, 256 rays on edges) that leaves the corners 0.0109 px
// RMS off, varying slowly along a side; along the rows 0.0027. With noise, 72 views each: 60 px
// 0.0108 -> 0.0061, 30 px 0.0171 -> 0.0088, 16 px 0.0213 -> 0.0144; the sun sweep's shadow-edge
// views 0.0271 -> 0.0277.
bool AreaAlongPixelRow(const Sampler& sample, const Eigen::Vector2d& centre,
                       const Eigen::Vector2d& outward, double W, double best,
                       Eigen::Vector2d* edge_out, double* strength) {
  const bool along_x = std::abs(outward.x()) >= std::abs(outward.y());
  const double cos_axis = along_x ? std::abs(outward.x()) : std::abs(outward.y());
  if (!(cos_axis > 0.5) || !centre.allFinite()) return false;  // a unit vector's larger part
  const double sgn = (along_x ? outward.x() : outward.y()) > 0 ? 1 : -1;
  const Eigen::Vector2d u(-outward.y(), outward.x());  // along the edge
  Eigen::Vector2d c = centre;
  if (along_x)
    c += (std::round(c.y()) - c.y()) / u.y() * u;
  else
    c += (std::round(c.x()) - c.x()) / u.x() * u;
  const double row = along_x ? c.y() : c.x();  // a whole pixel
  // Along the row: coordinates relative to the whole pixel k0 at or below the centre, which is
  // at k0 + frac; pix[k - lo] is the value of pixel k0 + k, over the window and one beyond.
  const double k0 = std::floor(along_x ? c.x() : c.y());
  const double frac = (along_x ? c.x() : c.y()) - k0;
  const double reach = W / cos_axis, band = 0.5 / cos_axis;
  const int lo = static_cast<int>(std::floor(frac - reach)) - 1;
  const int hi = static_cast<int>(std::ceil(frac + reach)) + 1;
  std::array<double, 20> pix{};
  static_assert(2 * kMaxRowWindowPx * 1.4143 + 5 <= 20, "the widest window at 45 degrees fits");
  if (hi - lo + 1 > static_cast<int>(pix.size())) return false;
  for (int k = lo; k <= hi; ++k) pix[k - lo] = along_x ? sample(k0 + k, row) : sample(row, k0 + k);
  // The integral of the linear interpolant between pixel centres over [a, b] (any order).
  auto integral = [&](double a, double b) {
    if (a > b) std::swap(a, b);
    double sum = 0;
    for (int k = static_cast<int>(std::floor(a)); k < b; ++k) {
      const double t0 = std::max(a, static_cast<double>(k)), t1 = std::min(b, k + 1.0);
      const double v0 = pix[k - lo], dv = pix[k + 1 - lo] - v0;
      sum += (t1 - t0) * (v0 + 0.5 * (t0 + t1 - 2 * k) * dv);
    }
    return sum;
  };
  const double dark_end = frac - sgn * reach, bright_end = frac + sgn * reach;
  const double dark = integral(dark_end, dark_end + sgn * band) / band;
  const double bright = integral(bright_end - sgn * band, bright_end) / band;
  if (bright - dark < 0.3 * best) return false;
  const double bright_len = (integral(dark_end, bright_end) - 2 * reach * dark) / (bright - dark);
  const double from_dark_end = std::clamp(2 * reach - bright_len, 0.0, 2 * reach);
  const double axis = k0 + dark_end + sgn * from_dark_end;
  *edge_out = along_x ? Eigen::Vector2d(axis, row) : Eigen::Vector2d(row, axis);
  *strength = best;
  return true;
}

// See LocateEdgeWith: the fall of a narrow band's profile, as a fraction of its contrast, from
// its brightest point to the window's end that marks a darker region beyond it.
constexpr double kNarrowBandDrop = 0.02;

// The half-width (pixels, across the edge) of the window in which AreaAlongPixelRow takes an
// edge's area, from the spread of the edge's profile `prof` (samples `h` apart over +-2 px
// across it, centred near the edge): 2 px for a sharp edge, wider for a blurred one, at most
// `max_window`. Why: the window's levels are read in its outer 0.5 px, from the linear
// interpolant between pixels; where a blurred edge has not reached its plateaus there, the two
// levels fall short by different amounts at each pixel phase and the edge moves. Noise-free
// straight edges at 0-45 degrees behind a Gaussian blur of sigma 0.5 to 1.0 px are found
// within 0.01 px at +-3.5 px, and up to 0.11 px off at +-2 (corner_refine_test:
// LocateEdge.ABlurredEdgeIsFoundWithAWiderWindow). The spread (the standard deviation of the
// profile's rising steps about their mean) is 0.36-0.58 px on sharp edges (pixels only, by
// angle) and 0.67 / 0.80 / 0.92 at those blurs (truncated by the +-2 px it is measured over);
// sharp edges keep 2 px, whose noise is least. At most kMaxRowWindowPx.
double RowWindow(const std::array<double, 17>& prof, double h, double max_window) {
  double sw = 0, sx = 0, sxx = 0;
  const int n = static_cast<int>(prof.size()) - 1;
  for (int i = 0; i < n; ++i) {
    const double rise = std::max(0.0, prof[i + 1] - prof[i]), x = (i + 0.5 - 0.5 * n) * h;
    sw += rise;
    sx += rise * x;
    sxx += rise * x * x;
  }
  if (!(sw > 0)) return kMinRowWindowPx;
  const double spread = std::sqrt(std::max(0.0, sxx / sw - (sx / sw) * (sx / sw)));
  return std::clamp(kMinRowWindowPx + 6.0 * (spread - 0.55), kMinRowWindowPx,
                    std::clamp(max_window, kMinRowWindowPx, kMaxRowWindowPx));
}

// The edge crossing `p` where the intensity rises along `outward` (unit, pixels), searched
// over +-steps half-pixel steps; `line` has room for 2 steps + 3 samples. *strength: the
// derivative's peak (grey levels per pixel). False where no rising edge stands out; then
// *rises_past_end (when given) says whether the steepest rise was at the search's outward end.
// `along_rows`: across a wide band, the area is taken again along the pixel row through the
// point found (AreaAlongPixelRow), over +-2 px across the edge, or up to +-max_row_window px
// where the edge is blurred (RowWindow).
// What LocateEdgeWith read across a narrow band (a small marker's stripe): the steepest 1 px
// rise over the height of the bright level it normalised the profile by above the dark side
// (bright - dark; BlurredBandBias).
struct BandReading {
  double rise = 0;
};

// The median of the readings' rises, reordering them in place (svms/base/statistics.h's Median
// copies its vector: an allocation per call, and the C API promises none after warm-up).
double MedianInPlace(std::vector<BandReading>* v) {
  const auto by_rise = [](const BandReading& a, const BandReading& b) { return a.rise < b.rise; };
  const size_t h = v->size() / 2;
  std::nth_element(v->begin(), v->begin() + h, v->end(), by_rise);
  const double upper = (*v)[h].rise;
  if (v->size() % 2) return upper;
  return 0.5 * (upper + std::max_element(v->begin(), v->begin() + h, by_rise)->rise);
}

bool LocateEdgeWith(const Sampler& sample, double* line, int steps, const Eigen::Vector2d& p,
                    const Eigen::Vector2d& outward, bool narrow_band, Eigen::Vector2d* edge_out,
                    double* strength, bool* rises_past_end = nullptr, bool along_rows = false,
                    double max_row_window = 2.0, std::vector<BandReading>* bands = nullptr) {
  // Derivative of intensity along the outward normal at 0.5 px steps s: the difference
  // of the samples 0.5 px either side, I(s + 1) - I(s - 1) on the half-pixel grid.
  double best = 0;
  int best_s = 0;
  for (int j = 0; j < 2 * steps + 3; ++j) {
    const Eigen::Vector2d q = p + 0.5 * (j - steps - 1) * outward;
    line[j] = sample(q.x(), q.y());
  }
  for (int s = -steps + 1; s < steps; ++s) {
    const double deriv = line[s + steps + 2] - line[s + steps];
    if (deriv > best) {
      best = deriv;
      best_s = s;
    }
  }
  if (rises_past_end) *rises_past_end = best > 0 && best_s == steps - 1;
  if (best <= 0 || best_s == -steps + 1 || best_s == steps - 1) return false;
  // The edge position from the area under the normalised profile, in a window centred on
  // the derivative's peak: for a step seen through box-filtered pixels (and any
  // symmetric blur) the bright length is the integral, whatever the pixel phase -- the
  // peak of the derivative alone locks toward pixel centres on sharp edges. With along_rows,
  // across a wide band, that point is then the centre of the same area taken along the pixel row
  // (AreaAlongPixelRow), which the bilinear profile's pixel-phase error does not reach.
  const Eigen::Vector2d centre = p + 0.5 * best_s * outward;
  constexpr double W = 2.0, h = 0.25;

  const int ns = static_cast<int>(2 * W / h);
  double dark = 0, bright = 0, area = 0;
  std::array<double, 17> prof{};
  // Every other profile point lies on the half-pixel grid already sampled into `line`
  // (line[j] is at p + 0.5 (j - steps - 1) outward): reused, a third of the samples saved.
  static_assert(W == 2.0 && h == 0.25, "the reuse below assumes 0.25 px steps over +-2 px");
  for (int i = 0; i <= ns; ++i) {
    const int j = best_s + (i - 8) / 2 + steps + 1;
    if (i % 2 == 0 && j >= 0 && j < 2 * steps + 3) {
      prof[i] = line[j];
      continue;
    }
    const Eigen::Vector2d q = centre + (-W + i * h) * outward;
    prof[i] = sample(q.x(), q.y());
  }
  // Dark level: the window's first 3 samples. Bright level and the end of the integral: the
  // window's last 3 samples; but across a narrow bright band (narrow_band) whose profile falls
  // by more than kNarrowBandDrop of the contrast from its brightest point to the window's end,
  // that brightest point (the vertex of a parabola through the brightest sample and its
  // neighbours). The white stripe of an 8 px marker is 2.7 px wide, and a black bit cell beyond
  // it darkens the window's end: read there, the bright level comes out low and the edge
  // 0.05-0.2 px early (the corners of 8 px markers 0.13 px off RMS on the simulator, against
  // 0.06 from the brightest point). On wide bands the window's end is exact and the brightest
  // point is not: it falls where noise or shading puts it, short of the plateau (taking it for
  // every marker raises the median corner error on the noise-free angle set from 0.0069 to
  // 0.0085 px).
  for (int i = 0; i < 3; ++i) dark += prof[i] / 3;
  int top = ns;
  for (int i = ns / 2; i <= ns; ++i)
    if (prof[i] > prof[top]) top = i;
  double end_mean = 0;
  for (int i = 0; i < 3; ++i) end_mean += prof[ns - i] / 3;
  double peak = prof[top];
  if (top < ns) {
    const double a = prof[top - 1], b = prof[top], c = prof[top + 1];
    const double curv = a - 2 * b + c;
    peak = curv < 0 ? b - (a - c) * (a - c) / (8 * curv) : b;
  }
  if (!narrow_band || top >= ns || peak - end_mean <= kNarrowBandDrop * (peak - dark)) {
    bright = end_mean;
    top = ns;
  } else {
    bright = peak;
  }
  if (bright - dark < 0.3 * best) return false;
  for (int i = 0; i < top; ++i)
    area += 0.5 * (prof[i] + prof[i + 1] - 2 * dark) / (bright - dark) * h;
  const double offset = top * h - area - W;  // from the centre: -W + (top h - area)
  if (bands && narrow_band) bands->push_back({best / (bright - dark)});
  const Eigen::Vector2d edge = centre + std::clamp(offset, -W, W) * outward;
  if (!narrow_band && along_rows) {
    // Along the row, the window widens with the edge's blur (RowWindow) up to max_row_window.
    return AreaAlongPixelRow(sample, edge, outward, RowWindow(prof, h, max_row_window), best,
                             edge_out, strength);
  }
  *edge_out = edge;
  *strength = best;
  return true;
}

}  // namespace

double SampleImage(const cv::Mat& img, double u, double v) { return Sampler(img)(u, v); }

bool LocateEdge(const cv::Mat& image, const Eigen::Vector2d& p,
                const Eigen::Vector2d& dark_to_bright, double search_px, Eigen::Vector2d* edge,
                double* strength, bool narrow_band, bool along_rows, double max_row_window) {
  const int steps = std::clamp(static_cast<int>(std::ceil(search_px / 0.5)), 2, 30);
  std::array<double, 2 * 30 + 3> line;
  return LocateEdgeWith(Sampler(image), line.data(), steps, p, dark_to_bright, narrow_band, edge,
                        strength, nullptr, along_rows, max_row_window);
}

namespace {

// Maps pixels to the plane where lines are fitted, and back.
struct Plane {
  const CameraModel* camera;
  bool ToPlane(const Eigen::Vector2d& px, Eigen::Vector2d* q) const {
    if (!camera) {
      *q = px;
      return true;
    }
    Eigen::Vector3d d;
    if (!camera->Unproject(px, &d) || d.z() <= 0) return false;
    *q = d.head<2>() / d.z();
    return true;
  }
  bool ToPixel(const Eigen::Vector2d& q, Eigen::Vector2d* px) const {
    if (!camera) {
      *px = q;
      return true;
    }
    return camera->Project(Eigen::Vector3d(q.x(), q.y(), 1), px);
  }
};

// The mean of the samples 1.5, 1.75 and 2 px from `edge` along `dir` (pixels).
double LevelBeside(const Sampler& sample, const Eigen::Vector2d& edge, const Eigen::Vector2d& dir) {
  double sum = 0;
  for (double t : {1.5, 1.75, 2.0}) {
    const Eigen::Vector2d q = edge + t * dir;
    sum += sample(q.x(), q.y());
  }
  return sum / 3;
}

// True where more than half of up to 8 of a side's located edge points, evenly spread (pixels;
// `outward` from dark to bright), have their dark side, 1.5-2 px in, more than `fraction` of
// the way from the square's `black` to their bright side, 1.5-2 px out: the rise located is
// not the black square's. Eight, as in the study that set the threshold (BM_Detect, three
// markers: step 8 takes 0.230 ms without the check, 0.241 with it on 8 points, 0.248 on all).
bool InPenumbra(const Sampler& sample, const std::vector<Eigen::Vector2d>& edges,
                const Eigen::Vector2d& outward, double black, double fraction) {
  const size_t n = std::min<size_t>(8, edges.size());
  size_t raised = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& e = edges[(2 * i + 1) * edges.size() / (2 * n)];
    const double dark = LevelBeside(sample, e, -outward), bright = LevelBeside(sample, e, outward);
    if (bright > black && dark - black > fraction * (bright - black)) ++raised;
  }
  return 2 * raised > n;
}

// Where the profile from `edge` inward along -outward (0.25 px steps, up to `reach_px`) first
// falls to `level`, interpolated between the two samples around it (pixels); *strength: its
// fall there, grey levels per pixel. False where it does not fall that far within reach.
bool FallTo(const Sampler& sample, const Eigen::Vector2d& edge, const Eigen::Vector2d& outward,
            double level, double reach_px, Eigen::Vector2d* at, double* strength) {
  double prev = sample(edge.x(), edge.y());
  if (!(prev > level)) return false;  // already below it: no fall to place
  for (int i = 1; 0.25 * i <= reach_px; ++i) {
    const Eigen::Vector2d q = edge - 0.25 * i * outward;
    const double v = sample(q.x(), q.y());
    if (v <= level) {  // prev > level >= v
      *at = edge - (0.25 * (i - 1) + 0.25 * (prev - level) / (prev - v)) * outward;
      *strength = (prev - v) / 0.25;
      return true;
    }
    prev = v;
  }
  return false;
}

// The black square's edge under a penumbra, from the located (penumbra's) edge point `edge`:
// where the profile inward falls half-way from the stripe's shadowed level to `black`. That
// level is read first 1.5-2 px inside the penumbra's edge, which is already on its rise (the
// edge comes out 0.3-0.5 px outside, on the synthetic penumbra of corner_refine_test and on
// compare view edge_40deg_09), then again 0.5 px outside the edge so found, at the foot
// (0.05-0.09 px outside there).
bool EdgeBelowPenumbra(const Sampler& sample, const Eigen::Vector2d& edge,
                       const Eigen::Vector2d& outward, double black, double reach_px,
                       Eigen::Vector2d* inner, double* strength) {
  Eigen::Vector2d first;
  if (!FallTo(sample, edge, outward, black + 0.5 * (LevelBeside(sample, edge, -outward) - black),
              reach_px, &first, strength))
    return false;
  const Eigen::Vector2d foot = first + 0.5 * outward;
  const double stripe = sample(foot.x(), foot.y());
  return FallTo(sample, edge, outward, black + 0.5 * (stripe - black), reach_px, inner, strength);
}

// Buffers of RefineCorners, kept per thread between calls (no allocation once grown).
struct RefineScratch {
  std::vector<CodecBlock> codec_blocks;
  std::vector<double> line, weights, residual, signed_residual, abs_inliers;
  std::vector<Eigen::Vector2d> pts, edges, past_end;
  std::vector<char> use;
  std::vector<BandReading> bands;
};

// A bright band `w` px wide between two dark sides, blurred by a Gaussian of `sigma` px and
// integrated over square pixels, as LocateEdgeWith reads its near edge: *inward, how far
// inward of the true edge (toward the dark side) it places it, pixels, the mean over
// kBandPhases pixel phases, and *rise, the median of the rises it reads there (BandReading).
// The search is RefineCorners' at its default search_px (2.5 px: 5 half-pixel steps). Its
// half-pixel grid is laid from its start, and the answer depends on where that lies against
// the edge. Started at places spread over half a pixel about the edge, as here, it says 0.028 px
// on the 10.5-12.5 px squares behind 0.7 px of RefineCorners' test, where their sides lie
// 0.017 px inward; started twice, the second time from the first's mean place (as
// RefineCorners' last iteration starts on the line the one before fitted), 0.010. The spread
// start, the larger, is kept: the answer is a sigma term. False unless every phase located the
// edge. The band is drawn exactly (the closed-form integral of the blurred profile over each
// pixel) into a 2 x kBandPixels 16-bit strip; `readings` is scratch. The model's edge lies
// along the pixel columns; a real side lies at any angle.
constexpr int kBandPhases = 8, kBandPixels = 16;
bool ModelBand(double sigma, double w, std::vector<BandReading>* readings, double* inward,
               double* rise) {
  // The integral of Phi(t / sigma) from -inf to x.
  auto G = [sigma](double x) { return BlurredRamp(x, sigma); };
  // Phase k's strip, its true edge at 6 + (k + 1/2) / kBandPhases (the search reads pixels
  // 1-12 about it); the pixels' borders' integrals are each shared by two pixels.
  std::array<std::array<uint16_t, 2 * kBandPixels>, kBandPhases> strips;
  auto edge_of = [](int phase) { return 6 + (phase + 0.5) / kBandPhases; };
  std::array<double, kBandPixels + 1> near_edge, far_edge;
  for (int phase = 0; phase < kBandPhases; ++phase) {
    const double e = edge_of(phase);
    for (int x = 0; x <= kBandPixels; ++x) {
      near_edge[x] = G(x - 0.5 - e);
      far_edge[x] = G(x - 0.5 - e - w);
    }
    for (int x = 0; x < kBandPixels; ++x) {
      const double v = (near_edge[x + 1] - near_edge[x]) - (far_edge[x + 1] - far_edge[x]);
      strips[phase][x] = strips[phase][kBandPixels + x] =
          static_cast<uint16_t>(std::lround(1000 + 50000 * v));
    }
  }
  constexpr int kSteps = 5;
  std::array<double, 2 * kSteps + 3> line;
  readings->clear();
  double sum = 0;
  int located = 0;
  for (int phase = 0; phase < kBandPhases; ++phase) {
    const cv::Mat strip(2, kBandPixels, CV_16UC1, strips[phase].data());
    const double e = edge_of(phase);
    // The search's start within a quarter pixel of the edge, spread over half a pixel in
    // another order than the edge's phase.
    const double start = e - 0.25 + ((3 * phase) % kBandPhases + 0.5) / (2 * kBandPhases);
    Eigen::Vector2d edge;
    double best;
    if (!LocateEdgeWith(Sampler(strip), line.data(), kSteps, Eigen::Vector2d(start, 0.5),
                        Eigen::Vector2d(1, 0), true, &edge, &best, nullptr, false, 2.0, readings))
      continue;
    sum += e - edge.x();
    ++located;
  }
  *inward = located ? sum / located : 0;
  *rise = readings->empty() ? 0 : MedianInPlace(readings);
  return located == kBandPhases;
}

// ModelBand over a grid of blurs (kBandTableBlurs, evenly in their logarithm over
// kBandSigmaRange) and band widths (kBandTableWidths from kBandTableWidth0 px in steps of
// kBandTableWidthStep: the stripes of 6-14 px markers). A cell is valid where every phase
// located the edge (not so from a blur of 2.3 px on the narrowest bands).
constexpr int kBandTableBlurs = 24, kBandTableWidths = 14;
constexpr double kBandSigmaRange[2] = {0.15, 3.0};
constexpr double kBandTableWidth0 = 2.0, kBandTableWidthStep = 0.2;
struct BandTable {
  std::array<std::array<double, kBandTableWidths>, kBandTableBlurs> rise, inward;
  std::array<std::array<bool, kBandTableWidths>, kBandTableBlurs> valid;
};
BandTable BuildBandTable() {
  BandTable t;
  std::vector<BandReading> readings;
  for (int i = 0; i < kBandTableBlurs; ++i) {
    const double sigma = kBandSigmaRange[0] * std::pow(kBandSigmaRange[1] / kBandSigmaRange[0],
                                                       i / (kBandTableBlurs - 1.0));
    for (int j = 0; j < kBandTableWidths; ++j)
      t.valid[i][j] = ModelBand(sigma, kBandTableWidth0 + j * kBandTableWidthStep, &readings,
                                &t.inward[i][j], &t.rise[i][j]);
  }
  return t;
}
// Built when the library is loaded, in every program that loads svms_detect (the CLI, the
// Python module, the C API; about 3 ms), not on first use: the first small marker of a flight
// program's run would otherwise stall its frame and allocate after warm-up.
const BandTable kBandTable = BuildBandTable();

// How far inward a small marker's sides are placed behind a blur, in pixels, from the rises
// its stripe's profiles showed (`bands`, LocateEdgeWith): the stripe, `band_px` wide between
// the square and a black bit cell, never reaches its white there, and each profile is
// normalised by a bright level below it. The blur is the one whose ideal band (ModelBand: the
// same edge locator on an exactly drawn, noise-free band) gives the median rise the marker's
// profiles gave; the answer is the inward offset of that ideal band's edge, where it is inward
// (>= 0). Both from kBandTable, linear between its widths and, along the blur, between the
// two valid entries whose rises bracket the median (the first such pair from the sharpest;
// the rise falls as the blur grows); blurrier than the table's last valid entry, that entry's
// (an underestimate). Pooled over the marker because one profile's rise scatters with its
// pixel phase and noise. Beside a white bit cell the band is half as wide again and its
// profile is normalised by a brighter level: its rise reads lower, the blur larger, and on a
// stripe bordered mostly by white cells the answer is 1.5-2 times what a side beside black
// cells does (ModelBand on a band 1.5 times as wide, whose rise enters the median: 0.165 px
// for 0.103 at 0.7 px of blur on a 2.7 px stripe),
// while those sides do not lie inward at all. So the answer is an upper bound, carried in the
// corner sigmas and not subtracted (a correction that ignored the white cells made the
// corners worse: docs/benchmarks.md, Sensor profiles). 0 with fewer than 4 readings. The
// model leaves out the other edges' light in the 2-D profile and the noise, which raises the
// steepest rise a little (the blur then reads smaller).
double BlurredBandBias(double band_px, std::vector<BandReading>* bands) {
  if (bands->size() < 4) return 0;
  const double rise = MedianInPlace(bands);
  const double wf =
      std::clamp((band_px - kBandTableWidth0) / kBandTableWidthStep, 0.0, kBandTableWidths - 1.0);
  const int j = std::min(static_cast<int>(wf), kBandTableWidths - 2);
  const double f = wf - j;
  const BandTable& t = kBandTable;
  auto at = [&](const std::array<std::array<double, kBandTableWidths>, kBandTableBlurs>& v, int i) {
    return (1 - f) * v[i][j] + f * v[i][j + 1];
  };
  auto valid = [&](int i) { return t.valid[i][j] && t.valid[i][j + 1]; };
  if (!valid(0)) return 0;
  if (rise >= at(t.rise, 0)) return std::max(0.0, at(t.inward, 0));  // sharper than the table
  int i = 0;
  for (; i + 1 < kBandTableBlurs && valid(i + 1); ++i) {
    const double r0 = at(t.rise, i), r1 = at(t.rise, i + 1);
    if (r0 >= rise && rise >= r1) {
      const double g = r0 > r1 ? (r0 - rise) / (r0 - r1) : 0;
      return std::max(0.0, (1 - g) * at(t.inward, i) + g * at(t.inward, i + 1));
    }
  }
  return std::max(0.0, at(t.inward, i));  // blurrier than the last valid entry
}
RefineScratch& Scratch() { return ThreadScratch<RefineScratch>(); }

// A side's line in the fitting plane, a x + b y + c = 0 with (a, b) a unit normal.
struct LineFit {
  Eigen::Vector3d line = Eigen::Vector3d::Zero();
  int inliers = 0;
  // The inliers' scatter about the line, pixels: sqrt(sum r^2 / (n - 2)), the unbiased estimate
  // of one point's sigma (the line took two degrees of freedom; on a 10-point side of a small
  // marker sqrt(ss / n) is 11 % low, and its corners' sigmas with it).
  double rms_px = 0;
  // Sums for the lag-1 autocorrelation of the inliers' signed residuals along the side (in the
  // order of the points): sum r_i r_(i+1) over consecutive inliers, sum r_i^2, and the pairs.
  double lag1_products = 0, lag1_squares = 0;
  int lag1_pairs = 0;
};

// Weighted total least squares line through `pts`, refitted without the points farther from it
// than max(trim_sigmas x the robust sigma of the residuals, trim_floor_px): whatever crosses a
// side -- the post's silhouette at grazing angles, a shadow, an occluder -- moves its edge
// points off the line by pixels, and one such stretch biases a plain fit by tenths of a
// pixel at the corners. The robust sigma is 1.4826 x the median absolute residual.
LineFit FitLineRobust(const std::vector<Eigen::Vector2d>& pts, const std::vector<double>& weights,
                      const Plane& plane, const CornerRefineOptions& o) {
  RefineScratch& sc = Scratch();
  std::vector<char>& use = sc.use;
  use.assign(pts.size(), 1);
  LineFit fit;
  double px_per_unit = 1;
  for (int pass = 0; pass <= o.trim_passes; ++pass) {
    double wsum = 0;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < pts.size(); ++i) {
      if (!use[i]) continue;
      mean += weights[i] * pts[i];
      wsum += weights[i];
    }
    mean /= wsum;
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (size_t i = 0; i < pts.size(); ++i)
      if (use[i]) cov += weights[i] * (pts[i] - mean) * (pts[i] - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es;
    es.computeDirect(cov);  // closed form for 2 x 2
    const Eigen::Vector2d nrm = es.eigenvectors().col(0);
    fit.line = Eigen::Vector3d(nrm.x(), nrm.y(), -nrm.dot(mean));
    if (pass == 0 && plane.camera) {
      Eigen::Vector2d p0, p1;
      if (plane.ToPixel(mean, &p0) && plane.ToPixel(mean + 1e-3 * nrm, &p1))
        px_per_unit = (p1 - p0).norm() / 1e-3;
    }
    std::vector<double>&r = sc.residual, &abs_in = sc.abs_inliers;
    r.resize(pts.size());
    abs_in.clear();
    double ss = 0;
    fit.inliers = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      r[i] = px_per_unit * std::abs(nrm.dot(pts[i] - mean));
      if (!use[i]) continue;
      abs_in.push_back(r[i]);
      ss += r[i] * r[i];
      ++fit.inliers;
    }
    fit.rms_px = std::sqrt(ss / std::max(1, fit.inliers - 2));
    // The lag-1 sums of this fit (the loop may end after any pass).
    fit.lag1_products = fit.lag1_squares = 0;
    fit.lag1_pairs = 0;
    double previous = 0;
    bool have_previous = false;
    sc.signed_residual.resize(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
      const double signed_r = sc.signed_residual[i] = px_per_unit * nrm.dot(pts[i] - mean);
      if (!use[i]) {
        have_previous = false;
        continue;
      }
      fit.lag1_squares += signed_r * signed_r;
      if (have_previous) fit.lag1_products += previous * signed_r, ++fit.lag1_pairs;
      previous = signed_r, have_previous = true;
    }
    if (pass == o.trim_passes) break;
    std::nth_element(abs_in.begin(), abs_in.begin() + abs_in.size() / 2, abs_in.end());
    const double sigma = 1.4826 * abs_in[abs_in.size() / 2];
    const double cut = std::max(o.trim_sigmas * sigma, o.trim_floor_px);
    bool changed = false;
    int kept = 0;
    for (size_t i = 0; i < pts.size(); ++i) kept += r[i] <= cut;
    // Too few points left to trust a line more than the untrimmed one: keep the last fit.
    if (kept < std::max(o.trim_min_points, static_cast<int>(std::ceil(0.5 * pts.size())))) break;
    for (size_t i = 0; i < pts.size(); ++i) {
      const char u = r[i] <= cut;
      changed |= u != use[i];
      use[i] = u;
    }
    if (!changed) break;
  }
  return fit;
}
// Step 8's penumbra rule for one side (`outward`, length `len`; last_iteration: the refinement's
// last). A shadow's penumbra running along the side on the white stripe: see
// CornerRefineOptions::penumbra_dark_fraction. Taken from the located edges (*edges, their
// *weights) only in the last iteration: the earlier ones converge on the penumbra, a clean
// line to start from. But where the line is already on the square's edge and the penumbra's
// steepest rise lies beyond the search, most of the side's points find no edge, the rise
// running on past the search's end (*past_end; compare view edge_40deg_09 rendered with 256
// rays on edges): those ends are on the penumbra, and the edge is found under it from there,
// in any iteration. Under a penumbra, *edges and *weights are replaced by the square's edge
// found below it (EdgeBelowPenumbra); returns whether they were.
bool EdgesUnderPenumbra(const Sampler& sample, const CornerRefineOptions& o, double black,
                        double len, const Eigen::Vector2d& outward, bool last_iteration,
                        std::vector<Eigen::Vector2d>* edges_io, std::vector<double>* weights_io,
                        std::vector<Eigen::Vector2d>* past_end_io) {
  std::vector<Eigen::Vector2d>& edges = *edges_io;
  std::vector<double>& weights = *weights_io;
  std::vector<Eigen::Vector2d>& past_end = *past_end_io;
  const bool may_be_penumbra = std::isfinite(black) && len >= o.penumbra_min_side_px;
  const bool from_ends = may_be_penumbra && past_end.size() > edges.size() &&
                         InPenumbra(sample, past_end, outward, black, o.penumbra_dark_fraction);
  if (!(from_ends || (may_be_penumbra && last_iteration &&
                      InPenumbra(sample, edges, outward, black, o.penumbra_dark_fraction))))
    return false;
  if (from_ends) {
    edges.swap(past_end);
    weights.resize(edges.size());
  }
  const double reach = std::min(o.search_px + 2.5, 0.3 * len);
  size_t kept = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    Eigen::Vector2d inner;
    double strength;
    if (!EdgeBelowPenumbra(sample, edges[i], outward, black, reach, &inner, &strength)) continue;
    edges[kept] = inner;
    weights[kept++] = strength;
  }
  edges.resize(kept);
  weights.resize(kept);
  return true;
}

// The mean square of a Student-t variable with nu degrees of freedom, nu / (nu - 2): what a
// normal error over a sigma estimated with nu degrees of freedom gives on average. Capped at 3
// (nu held at 3 or more, NaN included): below nu = 2 the mean square is infinite, which two
// 3-point sides without pooling (pooled_prior_dof 0) can reach; with the default pooling nu is
// about 4 or more.
double StudentVarianceFactor(double nu) {
  if (!(nu > 3)) nu = 3;
  return nu / (nu - 2);
}

// Each corner's sigma (out->corner_sigma) from the four sides' line fits (out->side_points,
// ->side_rms; the lines in the fitting plane), side k's points spread over a fraction
// 1 - 2 margins[k] of it, and the lag-1 sums of their residuals.
// *perp: each side's perpendicular sigma at its ends (pixels), for CornerCovariance.
void CornerSigmas(const std::array<Eigen::Vector3d, 4>& lines, const std::array<double, 4>& margins,
                  double lag1_products, double lag1_squares, int lag1_pairs,
                  const std::array<double, 4>& block_factor, const CornerRefineOptions& o,
                  RefinedCorners* out_io, std::array<double, 4>* perp_out) {
  RefinedCorners& out = *out_io;
  // Neighbouring edge points (1.5 px apart) err together where the image was smoothed: by
  // the optics' blur, a JPEG's blocks, a demosaicing filter. Their scatter then says less
  // than independent points would: with a lag-1 correlation rho along the side, a line's
  // offset and slope have (1 + rho) / (1 - rho) times the variance the scatter gives (an
  // AR(1) model). rho is pooled over the four sides and taken only where it stands out of
  // its own noise (2 / sqrt(pairs)), so that white noise costs nothing.
  const double rho_raw = lag1_squares > 0 ? lag1_products / lag1_squares : 0;
  const double rho = rho_raw > 2 / std::sqrt(std::max(lag1_pairs, 1)) ? std::min(rho_raw, 0.9) : 0;
  out.correlation = rho;
  const double correlated = (1 + rho) / (1 - rho);
  // A line fitted to n points spread evenly over a fraction f of a side, residual RMS s: its
  // offset at the middle has variance s^2 / n and its slope s^2 / (n (f L)^2 / 12); at the
  // side's end (L / 2 away) the perpendicular variance is s^2 / n (1 + 3 / f^2).
  // Side k's variance, (dof_k s_k^2 + P s_pooled^2) / (dof_k + P) with s_pooled^2 =
  // sum_i dof_i s_i^2 / sum_i dof_i, is sum_i c[k][i] s_i^2 over the sides' own estimates s_i^2
  // (dof_i = n_i - 2 degrees of freedom each); its perpendicular variance at the ends is that
  // times mult[k].
  std::array<double, 4> dof, mult;
  std::array<std::array<double, 4>, 4> c;
  const double P = o.pooled_prior_dof;
  double pooled_dof = 0;
  for (int i = 0; i < 4; ++i) pooled_dof += dof[i] = std::max(1, out.side_points[i] - 2);
  std::array<double, 4> perp{};
  for (int k = 0; k < 4; ++k) {
    const double f = 1 - 2 * margins[k];
    mult[k] =
        std::max(correlated, block_factor[k]) * (1 + 3 / (f * f)) / std::max(1, out.side_points[k]);
    double var = 0;
    for (int i = 0; i < 4; ++i) {
      c[k][i] = ((i == k ? dof[k] : 0) + P * dof[i] / pooled_dof) / (dof[k] + P);
      var += c[k][i] * out.side_rms[i] * out.side_rms[i];
    }
    perp[k] = std::sqrt(mult[k] * var);
  }
  for (int k = 0; k < 4; ++k) {
    const int j = (k + 3) % 4;
    const double sin_angle =
        std::max(0.2, std::abs(lines[j].x() * lines[k].y() - lines[j].y() * lines[k].x()));
    double var = 0.5 * (perp[j] * perp[j] + perp[k] * perp[k]);
    if (o.small_sample_variance) {
      // The corner's variance is sum_i g_i s_i^2: where the sides share one sigma (as the
      // pooling assumes) its degrees of freedom are (sum g)^2 / sum g_i^2 / dof_i
      // (Satterthwaite), and its error over the sigma it gives is Student-t with as many.
      // Counted as n - 2 per side: where the points err together (rho > 0) or were trimmed,
      // fewer are independent, and the factor is then too small.
      double sum = 0, sum_sq = 0;
      for (int i = 0; i < 4; ++i) {
        const double g = 0.5 * (mult[j] * c[j][i] + mult[k] * c[k][i]);
        sum += g, sum_sq += g * g / dof[i];
      }
      var *= StudentVarianceFactor(sum * sum / sum_sq);
    }
    out.corner_sigma[k] = std::sqrt(var) / sin_angle;
  }
  *perp_out = perp;
}

// The corners' joint covariance (RefinedCorners::corner_covariance) from each side's
// perpendicular sigma at its ends, `perp` (pixels), the edge points spread over the middle
// fraction f = 1 - 2 margins[k] of side k. A side's line moves across itself by
// a + s b at the signed distance s from its middle (offset a, slope b independent for points
// centred on the middle): at its two ends, var(a) + (L/2)^2 var(b) each and
// var(a) - (L/2)^2 var(b) between them, with (L/2)^2 var(b) = 3 var(a) / f^2 for evenly spread
// independent points; where end_correlations[k] is finite (points that share errors within
// blocks: codec_blocks.h) the ends' correlation is that instead. A corner moves by N^-1 (d_prev,
// d_next), N the two sides' unit normals as rows, d their lines' moves across themselves at that
// corner; the same 0.2 floor on |det N| as corner_sigma's. The sides' angles are taken between the
// refined corners in pixels, while corner_sigma takes them between the lines in the fitting plane
// (undistorted through a lens model): each corner's rows and columns are then scaled so that its
// block's mean variance is corner_sigma^2 exactly (a congruence: the correlations, and positive
// definiteness, stay).
Eigen::Matrix<double, 8, 8> CornerCovariance(const std::array<Eigen::Vector2d, 4>& corners,
                                             const std::array<double, 4>& perp,
                                             const std::array<double, 4>& corner_sigma,
                                             const std::array<double, 4>& margins,
                                             const std::array<double, 4>& end_correlations) {
  // Moves across the sides: side k's at its start (corner k) is 2k, at its end 2k + 1.
  Eigen::Matrix<double, 8, 8> moves = Eigen::Matrix<double, 8, 8>::Zero();
  std::array<Eigen::Vector2d, 4> normal;
  for (int k = 0; k < 4; ++k) {
    const double v = perp[k] * perp[k];
    const double f = 1 - 2 * margins[k];
    const double end_correlation = std::isfinite(end_correlations[k])
                                       ? end_correlations[k]
                                       : (1 - 3 / (f * f)) / (1 + 3 / (f * f));
    moves(2 * k, 2 * k) = moves(2 * k + 1, 2 * k + 1) = v;
    moves(2 * k, 2 * k + 1) = moves(2 * k + 1, 2 * k) = end_correlation * v;
    const Eigen::Vector2d u = (corners[(k + 1) % 4] - corners[k]).normalized();
    normal[k] = Eigen::Vector2d(u.y(), -u.x());
  }
  Eigen::Matrix<double, 8, 8> A = Eigen::Matrix<double, 8, 8>::Zero();
  for (int k = 0; k < 4; ++k) {
    const int j = (k + 3) % 4;  // the side ending at corner k
    Eigen::Matrix2d N;
    N.row(0) = normal[j].transpose();
    N.row(1) = normal[k].transpose();
    const double det = std::abs(N.determinant());
    if (!(det > 0)) return Eigen::Matrix<double, 8, 8>::Zero();
    const Eigen::Matrix2d N_inv = N.inverse() * std::min(1.0, det / 0.2);
    A.block<2, 1>(2 * k, 2 * j + 1) = N_inv.col(0);
    A.block<2, 1>(2 * k, 2 * k) = N_inv.col(1);
  }
  Eigen::Matrix<double, 8, 8> C = A * moves * A.transpose();
  Eigen::Matrix<double, 8, 1> scale;
  for (int k = 0; k < 4; ++k) {
    const double own = 0.5 * C.block<2, 2>(2 * k, 2 * k).trace();
    if (!(own > 0)) return Eigen::Matrix<double, 8, 8>::Zero();
    scale.segment<2>(2 * k).setConstant(corner_sigma[k] / std::sqrt(own));
  }
  C = scale.asDiagonal() * C * scale.asDiagonal();
  return 0.5 * (C + C.transpose());  // exactly symmetric, whichever order it is read in
}

// Where a side's edge points are taken along the pixel rows (AreaAlongPixelRow), a point's
// window spans w px (kMinRowWindowPx, up to the widened row window) either side across the
// edge, along a row at the angle phi between the side's normal and the nearer pixel axis: its
// ends lie w tan(phi) px along the side from the point, and AreaAlongPixelRow first moves the
// point along the side onto a whole row, by up to 0.5 / cos(phi) px. Next to a corner the
// dark end then crosses the next side into the white stripe, and the edge moves: on 14-16 px
// markers with sides 35-45 degrees off the axes, 0.12 of each side left out (1.7-1.9 px) and
// windows of 2 px, the corners came out 0.083 px off RMS per axis behind 0.7 px of blur and
// 0.053 sharp (RefineCorners.NoRowWindowReachesPastACorner).
// AlongRowsMargin: the fraction of a side `len_px` long left out next to each corner: at least
// `end_margin`, and w tan(phi) + kRowWindowCornerClearPx (the corner's blur and the pixel) for
// the narrowest window (3 px at 45 degrees), at most kMaxAlongRowsMargin (which only a
// narrow_stripe_side_px under 10 px would reach). The row snap is left out of it: allowing for
// it there too cost sharp edges more than it gained on blurred ones (0.024 -> 0.030 px against
// 0.040 -> 0.036 on the test's markers), so a 2 px window's dark end may come within about
// 0.7 px of a corner (the margin leaves 1 - 0.5 / cos(phi), 0.29 px at 45 degrees, and the
// first point lies half a point spacing inside it: 0.71 px at worst, on 13.5 px sides at 45
// degrees). PointRowWindow: the widest window, at most `row_window`, that a point
// `from_corner_px` from the nearer corner may use with its row snap allowed for and the same
// clearance (at least kMinRowWindowPx). Narrower windows beside the corners rather than a
// margin for the widest window (which on Bayer frames, 3.5 px, left too few points).
constexpr double kRowWindowCornerClearPx = 1.0, kMaxAlongRowsMargin = 0.3;
double TanToRows(const Eigen::Vector2d& outward) {
  const double big = std::max(std::abs(outward.x()), std::abs(outward.y()));
  return big > 0 ? std::min(std::abs(outward.x()), std::abs(outward.y())) / big : 1;
}
double AlongRowsMargin(double end_margin, double len_px, double tan_phi) {
  const double px = kMinRowWindowPx * tan_phi + kRowWindowCornerClearPx;
  return std::clamp(px / len_px, end_margin, std::max(end_margin, kMaxAlongRowsMargin));
}
double PointRowWindow(double row_window, double from_corner_px, double tan_phi) {
  if (row_window <= kMinRowWindowPx || tan_phi <= 0) return row_window;
  const double snap_px = 0.5 * std::sqrt(1 + tan_phi * tan_phi);  // 0.5 / cos(phi)
  return std::clamp((from_corner_px - kRowWindowCornerClearPx - snap_px) / tan_phi, kMinRowWindowPx,
                    row_window);
}

}  // namespace

bool ExcludedRegion::Contains(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm() < radius;
}

RefinedCorners RefineCorners(const cv::Mat& img, const std::array<Eigen::Vector2d, 4>& in,
                             const CameraModel* camera, const CornerRefineOptions& o,
                             const std::vector<ExcludedRegion>& excluded, double black) {
  RefinedCorners out;
  out.corners = in;
  const Sampler sample(img);
  const int steps = static_cast<int>(std::ceil(o.search_px / 0.5));
  RefineScratch& sc = Scratch();
  std::vector<double>& line = sc.line;
  line.resize(2 * steps + 3);
  std::vector<Eigen::Vector2d>& pts = sc.pts;
  std::vector<Eigen::Vector2d>& edges = sc.edges;  // pixels
  // Where the steepest rise was at the search's outward end: the search's end (pixels).
  std::vector<Eigen::Vector2d>& past_end = sc.past_end;
  std::vector<double>& weights = sc.weights;
  // A pinhole camera maps straight sides to straight lines: fit in pixels, no unprojection.
  const bool pinhole = camera && camera->lensmodel() == "LENSMODEL_PINHOLE";
  const Plane plane{pinhole ? nullptr : camera};
  for (int it = 0; it < o.iterations; ++it) {
    std::array<Eigen::Vector3d, 4> lines;  // in the fitting plane
    double lag1_products = 0, lag1_squares = 0;
    int lag1_pairs = 0;
    std::array<SideBlocks, 4> blocks;
    // Only the last iteration's sigmas are kept: the blocks' share is estimated there alone.
    const bool last_iteration = o.codec_blocks && it == o.iterations - 1;
    double min_side = INFINITY;
    for (int k = 0; k < 4; ++k)
      min_side = std::min(min_side, (out.corners[(k + 1) % 4] - out.corners[k]).norm());
    const bool narrow_band = min_side < o.narrow_stripe_side_px;
    const double end_margin = narrow_band ? o.narrow_end_margin : o.end_margin;
    const double max_row_window = std::min(o.max_row_window_px, min_side / 3 - 2);
    const bool along_rows = o.edges_along_rows && !narrow_band;
    std::array<double, 4> margins;
    std::vector<BandReading>& bands = sc.bands;
    bands.clear();
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = out.corners[k], b = out.corners[(k + 1) % 4];
      const double len = (b - a).norm();
      const Eigen::Vector2d u = (b - a) / len, outward(u.y(), -u.x());  // dark is screen-right
      const double tan_phi = TanToRows(outward);
      margins[k] = along_rows ? AlongRowsMargin(end_margin, len, tan_phi) : end_margin;
      const double margin = margins[k];
      const int m = std::clamp(static_cast<int>(len / 1.5), 4, o.max_points);
      pts.clear();
      edges.clear();
      past_end.clear();
      weights.clear();
      for (int i = 0; i < m; ++i) {
        const double t = margin + (1 - 2 * margin) * (i + 0.5) / m;
        const Eigen::Vector2d p = a + t * (b - a);
        if (std::any_of(excluded.begin(), excluded.end(),
                        [&](const ExcludedRegion& e) { return e.Contains(p); })) {
          if (it == o.iterations - 1) ++out.excluded_points;
          continue;
        }
        Eigen::Vector2d edge;
        double best;
        bool rises_on;
        if (!LocateEdgeWith(sample, line.data(), steps, p, outward, narrow_band, &edge, &best,
                            &rises_on, o.edges_along_rows,
                            PointRowWindow(max_row_window, std::min(t, 1 - t) * len, tan_phi),
                            &bands)) {
          if (rises_on) past_end.push_back(p + 0.5 * steps * outward);
          continue;
        }
        edges.push_back(edge);
        weights.push_back(best);
      }
      // Under a shadow's penumbra along the side, the square's edge below it.
      if (EdgesUnderPenumbra(sample, o, black, len, outward, it == o.iterations - 1, &edges,
                             &weights, &past_end) &&
          it == o.iterations - 1)
        out.penumbra_sides[k] = true;
      size_t mapped = 0;
      for (size_t i = 0; i < edges.size(); ++i) {
        Eigen::Vector2d q;
        if (!plane.ToPlane(edges[i], &q)) continue;
        pts.push_back(q);
        edges[mapped] = edges[i];
        weights[mapped++] = weights[i];
      }
      edges.resize(mapped);
      weights.resize(mapped);
      if (pts.size() < 3) return out;  // not refined: keep what we had, ok = false
      const LineFit fit = FitLineRobust(pts, weights, plane, o);
      if (fit.inliers < 3) return out;
      lines[k] = fit.line;
      out.side_points[k] = fit.inliers;
      out.side_rms[k] = fit.rms_px;
      lag1_products += fit.lag1_products, lag1_squares += fit.lag1_squares;
      lag1_pairs += fit.lag1_pairs;
      if (last_iteration)
        blocks[k] = SideBlockSums(edges, sc.signed_residual, sc.use, a, b, &sc.codec_blocks);
    }
    // What the sides' points share within 8 x 8 blocks (codec_blocks.h): each side's factor
    // on its line's variance and the correlation of its ends; where none is found (c = 0, and
    // always without codec_blocks) the independent points' model, ends correlated as evenly
    // spread points' are (CornerCovariance).
    std::array<double, 4> block_factor, end_correlation;
    block_factor.fill(1);
    end_correlation.fill(NAN);
    out.block_correlation = 0;
    if (last_iteration) {
      const Eigen::Vector2d ac = BlockVariances(blocks);
      if (ac.y() > 0) {
        out.block_correlation = ac.y() / ac.sum();
        for (int k = 0; k < 4; ++k) {
          const SideLineEnds ends = SideLineVariance(blocks[k], ac);
          if (ends.ok) block_factor[k] = ends.factor, end_correlation[k] = ends.Correlation();
        }
      }
    }
    std::array<double, 4> perp;
    CornerSigmas(lines, margins, lag1_products, lag1_squares, lag1_pairs, block_factor, o, &out,
                 &perp);
    // A small marker's sides behind a blur lie inward by about band_bias_px, which their
    // scatter does not show: in each corner's sigma (and, through it, the joint covariance).
    // On the last iteration, whose sigmas are kept.
    out.band_bias_px = narrow_band && o.blurred_band_sigma && it == o.iterations - 1
                           ? BlurredBandBias(min_side / 3, &bands)
                           : 0;
    if (out.band_bias_px > 0)
      for (double& sigma : out.corner_sigma) sigma = std::hypot(sigma, out.band_bias_px);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d h = lines[(k + 3) % 4].cross(lines[k]);
      if (std::abs(h.z()) < 1e-15) return out;
      Eigen::Vector2d px;
      if (!plane.ToPixel(h.head<2>() / h.z(), &px)) return out;
      out.corners[k] = px;
    }
    // The joint covariance takes a side's edge points as independent or sharing errors within
    // blocks. Where neighbours err together along the side (out.correlation > 0: blur, a
    // JPEG's blocks, a demosaic) a side's line moves more as a whole than either says, and
    // its corners' correlation across it is not known: they are left as independent (zero
    // covariance).
    // Only the last iteration's lines are kept, so only their covariance is computed.
    if (it == o.iterations - 1)
      out.corner_covariance =
          out.correlation > 0
              ? Eigen::Matrix<double, 8, 8>::Zero()
              : CornerCovariance(out.corners, perp, out.corner_sigma, margins, end_correlation);
  }
  out.ok = true;
  return out;
}

}  // namespace svms
