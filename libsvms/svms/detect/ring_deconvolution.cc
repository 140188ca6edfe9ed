#include "svms/detect/ring_deconvolution.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "svms/codec/svms44.h"
#include "svms/marker/marker_model.h"

namespace svms {
namespace {

constexpr int kCells = Svms44::kBits;
// Regions of the unit plane (the square of side 1 centred on the origin).
constexpr int kSquare = 0, kStripe = 1, kFirstCell = 2, kQuiet = kFirstCell + kCells,
              kBeyond = kQuiet + 1, kCentre = kBeyond + 1, kRegions = kCentre + 1;
constexpr double kGridPx = 0.25;   // the footprints' sampling step, pixels
constexpr double kMaxSigmaPx = 4;  // blurs beyond this are not candidates (the grid's reach)
// The fit's pixels: within this many half-extents of the ring (1 = the ring's outer edge).
constexpr double kWindow = 1.3;
// The centre patch (half-side, unit plane): the post's silhouette and its tip near the middle
// of the square, whose light is not the square's (and a dual marker's inner marker, whose quiet
// zone reaches 0.29). The tip of the standard post (a quarter of the side high) lands within it
// up to about 45 degrees of tilt.
constexpr double kCentreHalf = 0.3;

// The bit index of each cell of the 12 x 12 grid of sixths from (-1, 1) (row 0 at the top), -1
// off the ring; from MarkerModel::BitCellCentre, so that the order is the codec's.
using CellGrid = std::array<std::array<int8_t, 12>, 12>;
const CellGrid& Cells() {
  static const CellGrid grid = [] {
    CellGrid g;
    for (auto& row : g) row.fill(-1);
    const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
    for (int i = 0; i < kCells; ++i) {
      const Eigen::Vector2d c = unit.BitCellCentre(i);
      const int cx = static_cast<int>(std::floor((c.x() + 1.0) * 6));
      const int cy = static_cast<int>(std::floor((1.0 - c.y()) * 6));
      g[cy][cx] = static_cast<int8_t>(i);
    }
    return g;
  }();
  return grid;
}

int RegionAt(double x, double y) {
  const double m = std::max(std::abs(x), std::abs(y));
  if (m < kCentreHalf) return kCentre;
  if (m < 0.5) return kSquare;
  if (m < 5.0 / 6) return kStripe;
  if (m < 1.0) {
    const int cx = std::clamp(static_cast<int>(std::floor((x + 1.0) * 6)), 0, 11);
    const int cy = std::clamp(static_cast<int>(std::floor((1.0 - y) * 6)), 0, 11);
    const int i = Cells()[cy][cx];
    return i < 0 ? kStripe : kFirstCell + i;
  }
  if (m < 7.0 / 6) return kQuiet;
  return kBeyond;
}

// The footprint of one pixel along one axis at offset t (pixels): its unit box convolved with a
// Gaussian of sigma s, Phi((t + 1/2) / s) - Phi((t - 1/2) / s).
double Footprint(double t, double s) {
  const double k = 1 / (s * std::sqrt(2.0));
  return 0.5 * (std::erf((t + 0.5) * k) - std::erf((t - 0.5) * k));
}

double Pixel(const cv::Mat& image, int x, int y) {
  return image.depth() == CV_16U ? image.at<uint16_t>(y, x) : image.at<uint8_t>(y, x);
}

}  // namespace

RingDeconvolution ReadRingDeconvolved(const cv::Mat& image, const Eigen::Matrix3d& pixel_from_unit,
                                      const RingDeconvolutionOptions& options,
                                      std::chrono::steady_clock::time_point deadline) {
  RingDeconvolution out;
  if (image.empty() || image.channels() != 1 ||
      (image.depth() != CV_8U && image.depth() != CV_16U) || options.blur_sigmas_px.empty())
    return out;
  const Eigen::Matrix3d unit_from_pixel = pixel_from_unit.inverse();
  auto to_pixel = [&](double x, double y, Eigen::Vector2d* p) {
    const Eigen::Vector3d h = pixel_from_unit * Eigen::Vector3d(x, y, 1);
    if (!(h.z() > 0)) return false;
    *p = h.head<2>() / h.z();
    return true;
  };
  // The window's bounding box, and the ring's longest side.
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  std::array<Eigen::Vector2d, 4> ring;
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {1, 1, -1, -1};
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector2d p;
    if (!to_pixel(kWindow * sx[k], kWindow * sy[k], &p) || !to_pixel(sx[k], sy[k], &ring[k]))
      return out;
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  for (int k = 0; k < 4; ++k)
    if (!((ring[k] - ring[(k + 1) % 4]).norm() <= options.max_extent_px)) return out;
  // A steep perspective can throw the window's corners far from a small ring: its cost grows
  // with its area, so a window more than twice the limit across is not read. Checked in floating
  // point before any conversion to int (NaN fails every comparison).
  if (!((hi - lo).maxCoeff() <= 2 * options.max_extent_px)) return out;
  if (!(lo.x() >= 0 && lo.y() >= 0 && hi.x() <= image.cols - 1 && hi.y() <= image.rows - 1))
    return out;
  // The candidate blurs: finite, positive, and under kMaxSigmaPx, sorted.
  std::vector<double> sigmas;
  for (double s : options.blur_sigmas_px)
    if (s > 0 && s <= kMaxSigmaPx) sigmas.push_back(s);
  std::sort(sigmas.begin(), sigmas.end());
  if (sigmas.empty()) return out;
  // Footprints reach 0.5 + 3 sigma from a pixel's centre.
  const int reach = static_cast<int>(std::ceil((0.5 + 3 * sigmas.back()) / kGridPx));
  const int px0 = static_cast<int>(std::floor(lo.x())), py0 = static_cast<int>(std::floor(lo.y()));
  const int px1 = static_cast<int>(std::ceil(hi.x())), py1 = static_cast<int>(std::ceil(hi.y()));
  if (px1 >= image.cols || py1 >= image.rows) return out;

  // The regions on the grid: pixel centres fall on every 4th grid point.
  constexpr int kPerPx = static_cast<int>(1 / kGridPx);
  const int gw = (px1 - px0) * kPerPx + 2 * reach + 1, gh = (py1 - py0) * kPerPx + 2 * reach + 1;
  std::vector<int8_t> grid(static_cast<size_t>(gw) * gh);
  for (int j = 0; j < gh; ++j)
    for (int i = 0; i < gw; ++i) {
      const double x = px0 + (i - reach) * kGridPx, y = py0 + (j - reach) * kGridPx;
      const Eigen::Vector3d u = unit_from_pixel * Eigen::Vector3d(x, y, 1);
      grid[static_cast<size_t>(j) * gw + i] =
          static_cast<int8_t>(u.z() > 0 ? RegionAt(u.x() / u.z(), u.y() / u.z()) : kBeyond);
    }
  // The fit's pixels.
  std::vector<Eigen::Vector2i> pixels;
  for (int y = py0; y <= py1; ++y)
    for (int x = px0; x <= px1; ++x) {
      const Eigen::Vector3d u = unit_from_pixel * Eigen::Vector3d(x, y, 1);
      if (u.z() > 0 && std::max(std::abs(u.x()), std::abs(u.y())) < kWindow * u.z())
        pixels.push_back({x, y});
    }
  out.pixels = static_cast<int>(pixels.size());
  if (out.pixels < 2 * kRegions) return out;

  // The fit under one blur: the albedos into *albedo and the squared residual, or infinity
  // where a region the reading needs (the square, the stripe, a cell) has almost no pixel or
  // the normal equations cannot be solved.
  std::vector<double> kernel, prefix;
  auto fit = [&](double sigma, Eigen::Matrix<double, kRegions, 1>* albedo) {
    const int taps = static_cast<int>(std::ceil((0.5 + 3 * sigma) / kGridPx));
    kernel.resize(2 * taps + 1);
    double ksum = 0;
    for (int t = -taps; t <= taps; ++t) ksum += kernel[t + taps] = Footprint(t * kGridPx, sigma);
    for (double& k : kernel) k /= ksum;
    prefix.resize(kernel.size() + 1);
    prefix[0] = 0;
    for (size_t t = 0; t < kernel.size(); ++t) prefix[t + 1] = prefix[t] + kernel[t];
    Eigen::Matrix<double, kRegions, kRegions> normal =
        Eigen::Matrix<double, kRegions, kRegions>::Zero();
    Eigen::Matrix<double, kRegions, 1> rhs = Eigen::Matrix<double, kRegions, 1>::Zero();
    double sum_i2 = 0;
    std::array<double, kRegions> w;
    std::array<int, kRegions> seen;
    for (const Eigen::Vector2i& p : pixels) {
      w.fill(0);
      const int ci = (p.x() - px0) * kPerPx + reach, cj = (p.y() - py0) * kPerPx + reach;
      // Along each grid row of the footprint the regions come in runs of a few pixels: each run
      // adds its share of the kernel at once (prefix sums), not tap by tap.
      for (int b = -taps; b <= taps; ++b) {
        const int8_t* row = &grid[static_cast<size_t>(cj + b) * gw + ci];
        const double kb = kernel[b + taps];
        int start = -taps;
        for (int a = -taps + 1; a <= taps + 1; ++a) {
          if (a <= taps && row[a] == row[start]) continue;
          w[row[start]] += kb * (prefix[a + taps] - prefix[start + taps]);
          start = a;
        }
      }
      int n = 0;
      for (int r = 0; r < kRegions; ++r)
        if (w[r] > 1e-9) seen[n++] = r;
      const double v = Pixel(image, p.x(), p.y());
      sum_i2 += v * v;
      for (int a = 0; a < n; ++a) {
        const double wa = w[seen[a]];
        rhs(seen[a]) += wa * v;
        for (int b = a; b < n; ++b) normal(seen[b], seen[a]) += wa * w[seen[b]];
      }
    }
    // The square, the stripe and every cell must have pixels: a blur whose footprints leave
    // one almost unseen gives no reading.
    for (int r = 0; r < kQuiet; ++r)
      if (normal(r, r) < 0.05) return std::numeric_limits<double>::infinity();
    // The regions beyond and at the centre may be missing: a small ridge keeps the solve
    // defined.
    const double ridge = 1e-9 * normal.trace();
    for (int r = 0; r < kRegions; ++r) normal(r, r) += ridge;
    const Eigen::LDLT<Eigen::Matrix<double, kRegions, kRegions>, Eigen::Lower> ldlt(normal);
    if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
    *albedo = ldlt.solve(rhs);
    return std::max(0.0, sum_i2 - albedo->dot(rhs));
  };

  // The blur: from the middle candidate downhill along the sorted candidates to a local minimum
  // of the residual (it falls toward the image's blur and rises past it), so the widest,
  // dearest footprints are fitted only when the image asks for them. A candidate whose fit
  // fails counts as an infinite residual; where the one reached is such, there is no reading.
  std::vector<double> ss(sigmas.size(), -1);
  std::vector<Eigen::Matrix<double, kRegions, 1>> albedos(sigmas.size());
  const bool timed = deadline != std::chrono::steady_clock::time_point::max();
  auto residual = [&](size_t k) {
    if (ss[k] < 0) {
      if (timed && std::chrono::steady_clock::now() >= deadline) {
        out.out_of_time = true;
        return std::numeric_limits<double>::infinity();
      }
      ss[k] = fit(sigmas[k], &albedos[k]);
    }
    return ss[k];
  };
  size_t k = sigmas.size() / 2;
  for (;;) {
    const double here = residual(k);
    if (out.out_of_time) return out;
    if (k > 0 && residual(k - 1) < here) {
      --k;
    } else if (k + 1 < sigmas.size() && residual(k + 1) < here) {
      ++k;
    } else {
      break;
    }
  }
  if (out.out_of_time) return out;
  const double best_ss = ss[k];
  if (!std::isfinite(best_ss)) return out;
  const Eigen::Matrix<double, kRegions, 1>& best_albedo = albedos[k];
  out.blur_sigma_px = sigmas[k];
  out.black = best_albedo(kSquare);
  out.white = best_albedo(kStripe);
  const double threshold = 0.5 * (out.black + out.white);
  for (int i = 0; i < kCells; ++i) {
    out.cell[i] = best_albedo(kFirstCell + i);
    if (out.cell[i] > threshold) out.word |= uint64_t{1} << i;
  }
  out.residual_rms = std::sqrt(best_ss / (out.pixels - kRegions));
  // A stripe no brighter than the square by three times the fit's own scatter (a flat patch,
  // a texture's quadrilateral) is not a ring to read.
  out.ok = out.white - out.black > std::max(3 * out.residual_rms, 1e-6 * std::abs(out.white));
  return out;
}

}  // namespace svms
