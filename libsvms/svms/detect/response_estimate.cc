#include "svms/detect/response_estimate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <utility>

#include "svms/camera/photometric.h"
#include "svms/geometry/quad_sides.h"

namespace svms {

void CollectEdgePatches(const cv::Mat& stored, const std::vector<Detection>& detections,
                        double black_level, double white_level, std::vector<EdgePatch>* out,
                        size_t max_patches) {
  if (stored.empty() || stored.channels() != 1 ||
      (stored.depth() != CV_8U && stored.depth() != CV_16U))
    return;
  const double white = white_level > 0 ? white_level : (stored.depth() == CV_8U ? 255 : 65535);
  const double range = white - black_level;
  if (!(range > 0)) return;
  // Sides number on from the last marker's four, so that side / 4 names a marker.
  uint32_t side = out->empty() ? 0 : (out->back().side / 4 + 1) * 4;
  for (const Detection& d : detections) {
    const Eigen::Vector2d centre = QuadCentroid(d.corners);
    for (int k = 0; k < 4; ++k, ++side) {
      const Eigen::Vector2d a = d.corners[k], b = d.corners[(k + 1) % 4];
      const double length = (b - a).norm();
      const Eigen::Vector2d along = (b - a) / length;
      const Eigen::Vector2d outward = OutwardNormal(a, b, centre);
      // The white stripe is a third of the square's side wide; across this side, that is a
      // third of the neighbouring sides as they cross it (the view foreshortens them, not it).
      const Eigen::Vector2d before = d.corners[(k + 3) % 4] - a, after = d.corners[(k + 2) % 4] - b;
      const double room = std::min(std::abs(before.dot(outward)), std::abs(after.dot(outward))) / 3;
      if (!(room >= 4)) continue;
      // Along the side, the patches stop 3 px short of the corners, beyond the neighbouring
      // sides' blur.
      const double half_along = std::min(kPatchHalfAlong, 0.25 * length - 3);
      if (!(half_along >= 2)) continue;
      for (double u : {0.25, 0.375, 0.5, 0.625, 0.75}) {
        if (out->size() >= max_patches) return;
        const Eigen::Vector2d p = a + u * (b - a);
        const double reach = std::hypot(kPatchHalfAcross, half_along);
        if (!(p.x() - reach >= 0 && p.y() - reach >= 0 && p.x() + reach < stored.cols - 1 &&
              p.y() + reach < stored.rows - 1))
          continue;
        const int x0 = static_cast<int>(std::floor(p.x() - reach)),
                  x1 = static_cast<int>(std::ceil(p.x() + reach)),
                  y0 = static_cast<int>(std::floor(p.y() - reach)),
                  y1 = static_cast<int>(std::ceil(p.y() + reach));
        if (x0 < 0 || y0 < 0 || x1 >= stored.cols || y1 >= stored.rows) continue;
        EdgePatch patch;
        patch.black = static_cast<float>(black_level);
        patch.range = static_cast<float>(range);
        patch.room = static_cast<float>(room);
        patch.side = side;
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            const Eigen::Vector2d q(x - p.x(), y - p.y());
            const double across = q.dot(outward), s = q.dot(along);
            if (std::abs(across) > kPatchHalfAcross || std::abs(s) > half_along) continue;
            patch.code.push_back(stored.depth() == CV_8U ? stored.at<uint8_t>(y, x)
                                                         : stored.at<uint16_t>(y, x));
            patch.across.push_back(static_cast<float>(across));
            patch.along_weight.push_back(
                static_cast<float>(std::exp(-s * s / (2 * kPatchAlongSigma * kPatchAlongSigma))));
            patch.half.push_back(s >= 0);
          }
        out->push_back(std::move(patch));
      }
    }
  }
}

namespace {

// The moments of a patch's line spread function E' (E its edge spread function, read through a
// candidate curve and normalised between its plateaus) about its centre c, under a Gaussian
// taper T of kTaper px: m_k = integral of t^k T(t) E'(t) dt, t = x - c. Computed by parts,
//   m_k = -integral of (t^k T)'(t) (E(t) - B(t)) dt  (+ the same moment of B'),
// with B a symmetric smooth step (a normal CDF of kStep px) about c: E - B vanishes on both
// plateaus, so the integral stops at +-kWindow px, where the next edge has not begun, and B's
// own odd moments are zero. Each integral is a sum over the patch's pixels (their area is one
// px^2; along the edge, the pixels' weights integrate the Gaussian along it).
constexpr double kTaper = 1.5;                          // px
constexpr double kStep = 1.0;                           // px
constexpr double kWindow = 3.0;                         // px
constexpr double kPlateauFrom = 2.5, kPlateauTo = 3.5;  // px either side of the centre

// The weights (t^k T)' for k = 1, 2, 3, the step's shape, and B's own moments, tabulated
// over +-kTableReach px (read with linear interpolation).
struct Kernels {
  static constexpr double kTableReach = 4.5, kTableStep = 1.0 / 128;
  static constexpr int kSize = static_cast<int>(2 * kTableReach / kTableStep) + 2;
  std::array<std::array<float, kSize>, 4> table{};  // (t T)', (t^2 T)', (t^3 T)', Phi(t / kStep)
  double gain = 0;  // d m_1 / d(shift of the edge), for B's shape: the centre's Newton step
  double b_m2 = 0;  // B's own second moment under the taper
  // The taper, a Gaussian of kTaper px, and its derivative.
  static double Taper(double t, double* derivative) {
    const double g = std::exp(-t * t / (2 * kTaper * kTaper));
    *derivative = -t / (kTaper * kTaper) * g;
    return g;
  }
  Kernels() {
    for (int i = 0; i < kSize; ++i) {
      const double t = -kTableReach + i * kTableStep;
      double dT = 0;
      const double T = Taper(t, &dT);
      table[0][i] = static_cast<float>(T + t * dT);
      table[1][i] = static_cast<float>(2 * t * T + t * t * dT);
      table[2][i] = static_cast<float>(3 * t * t * T + t * t * t * dT);
      table[3][i] = static_cast<float>(0.5 * std::erfc(-t / (kStep * std::sqrt(2.0))));
    }
    constexpr int kN = 6000;
    for (int i = 0; i <= kN; ++i) {
      const double t = -kWindow + 2 * kWindow * i / kN, dt = 2 * kWindow / kN;
      double dT = 0;
      const double T = Taper(t, &dT);
      const double b = std::exp(-t * t / (2 * kStep * kStep)) / (kStep * std::sqrt(2 * M_PI));
      gain += (T + t * dT) * b * dt;
      b_m2 += t * t * T * b * dt;
    }
  }
  float operator()(int k, double t) const {
    const double f =
        (std::clamp(t, -kTableReach, kTableReach - kTableStep) + kTableReach) / kTableStep;
    const int i = static_cast<int>(f);
    const double w = f - i;
    return static_cast<float>((1 - w) * table[k][i] + w * table[k][i + 1]);
  }
};

const Kernels& TheKernels() {
  static const Kernels kernels;
  return kernels;
}

// The patches with the scale each is read on ((code - black) / range), each scale's largest
// code, and whether each patch's blur leaves its plateaus clear of the next edge: found once
// for all the candidate curves.
struct PatchSet {
  std::vector<const EdgePatch*> patch;
  std::vector<int> scale;                       // per patch, an index into `scales`
  std::vector<std::pair<float, float>> scales;  // (black, range)
  std::vector<size_t> codes;                    // per scale, the largest code + 1
};

struct Moments {
  bool ok = false;
  double m2 = 0, m3 = 0;
};

// The moments of one patch read through `lut` (see Kernels).
Moments PatchMoments(const EdgePatch& p, const std::vector<double>& lut, std::vector<double>* v) {
  const Kernels& K = TheKernels();
  const size_t n = p.code.size();
  v->resize(n);
  for (size_t i = 0; i < n; ++i) (*v)[i] = lut[p.code[i]];
  Moments out;
  // The plateaus' levels, from the pixels kPlateauFrom..kPlateauTo px either side of `c`: taken
  // about the centre rather than the edge as found, since the weights at the window's end
  // (where (t^3 T) is near its peak) carry any error of those levels into the third moment.
  double dark = 0, contrast = 0;
  auto plateaus = [&](double c) {
    double d = 0, d_w = 0, b = 0, b_w = 0;
    for (size_t i = 0; i < n; ++i) {
      const double t = p.across[i] - c, a = std::abs(t);
      if (a < kPlateauFrom || a > kPlateauTo) continue;
      (t < 0 ? d : b) += p.along_weight[i] * (*v)[i];
      (t < 0 ? d_w : b_w) += p.along_weight[i];
    }
    if (!(d_w > 0 && b_w > 0)) return false;
    dark = d / d_w, contrast = b / b_w - dark;
    return contrast > 0.05;
  };
  // The centre from one half of the patch (along the edge), the moments about it from the other,
  // and the two ways averaged: a centre found from the same pixels would share their noise, and
  // under shot noise (the bright side noisier) that biases the third moment. The centre is
  // iterated to 1e-4 px: the Newton step's gain is B's, which differs from a sharper or blurrier
  // edge's, and an unconverged centre leaves part of the offset of the edge as found, which
  // skews the moments. A centre over 1 px from the edge as found leaves the patch out.
  double m2 = 0, m3 = 0;
  for (int h = 0; h < 2; ++h) {
    // With noise, the plateaus re-read about each new centre and the window's hard ends can
    // leave no exact zero: the iteration then bounces between two centres a few thousandths of
    // a pixel apart and the patch is left out (1-8 % of patches at 1-2 grey levels of noise, in
    // a re-implementation by review). Taking the bounce's midpoint instead kept them and read
    // the noisy boards lower (2.186 against 2.194, seed 1): those patches' centres are biased.
    // Smooth ends for the plateaus and the window would remove the bounce; not built.
    double c = 0;
    bool converged = false;
    for (int iteration = 0; iteration < 30 && !converged; ++iteration) {
      if (!plateaus(c)) return out;
      double s1 = 0, length = 0;
      for (size_t i = 0; i < n; ++i) {
        if (p.half[i] != h) continue;
        const double t = p.across[i] - c;
        if (std::abs(t) > kWindow) continue;
        const double w = p.along_weight[i];
        length += w;
        s1 -= w * K(0, t) * (((*v)[i] - dark) / contrast - K(3, t));
      }
      length /= 2 * kWindow;  // the along weights' integral
      if (!(length > 0)) return out;
      const double step = s1 / length / K.gain;
      c += step;
      if (!(std::abs(c) <= 1)) return out;
      converged = std::abs(step) < 1e-4;
    }
    if (!converged || !plateaus(c)) return out;
    double s2 = 0, s3 = 0, length = 0;
    for (size_t i = 0; i < n; ++i) {
      if (p.half[i] == h) continue;
      const double t = p.across[i] - c;
      if (std::abs(t) > kWindow) continue;
      const double r = ((*v)[i] - dark) / contrast - K(3, t);
      const double w = p.along_weight[i];
      length += w;
      s2 -= w * K(1, t) * r, s3 -= w * K(2, t) * r;
    }
    length /= 2 * kWindow;
    if (!(length > 0)) return out;
    m2 += 0.5 * (s2 / length + K.b_m2);
    m3 += 0.5 * s3 / length;
  }
  out.m2 = m2, out.m3 = m3;
  out.ok = m2 > 0;
  return out;
}

std::vector<std::vector<double>> Tables(const PatchSet& set,
                                        const std::function<double(double)>& to_linear) {
  std::vector<std::vector<double>> tables(set.scales.size());
  for (size_t s = 0; s < tables.size(); ++s) {
    const auto [black, range] = set.scales[s];
    tables[s].resize(set.codes[s]);
    for (size_t c = 0; c < tables[s].size(); ++c)
      tables[s][c] = to_linear(std::clamp((static_cast<float>(c) - black) / range, 0.0f, 1.0f));
  }
  return tables;
}

// The patches whose blur (4 sigma of the line spread function, read as linear) stays inside
// their room beyond the plateau window.
PatchSet Prepare(const std::vector<EdgePatch>& patches) {
  PatchSet all;
  std::map<std::pair<float, float>, int> index;
  for (const EdgePatch& p : patches) {
    // A patch built elsewhere with its per-pixel fields out of step is left out.
    const size_t n = p.code.size();
    if (n == 0 || p.across.size() != n || p.along_weight.size() != n || p.half.size() != n ||
        !(p.range > 0) || !std::isfinite(p.range) || !std::isfinite(p.black) ||
        !std::isfinite(p.room))
      continue;
    bool finite = true;
    for (size_t i = 0; i < n && finite; ++i)
      finite = std::isfinite(p.across[i]) && std::isfinite(p.along_weight[i]) &&
               p.along_weight[i] >= 0 && p.half[i] <= 1;
    if (!finite) continue;
    const auto [it, added] =
        index.emplace(std::pair{p.black, p.range}, static_cast<int>(all.scales.size()));
    if (added) all.scales.push_back(it->first), all.codes.push_back(0);
    const uint16_t top = *std::max_element(p.code.begin(), p.code.end());
    all.codes[it->second] = std::max(all.codes[it->second], static_cast<size_t>(top) + 1);
    all.patch.push_back(&p);
    all.scale.push_back(it->second);
  }
  const auto tables = Tables(all, [](double v) { return v; });
  PatchSet set = all;
  set.patch.clear(), set.scale.clear();
  std::vector<double> v;
  for (size_t m = 0; m < all.patch.size(); ++m) {
    const Moments mo = PatchMoments(*all.patch[m], tables[static_cast<size_t>(all.scale[m])], &v);
    if (mo.ok && all.patch[m]->room - kPlateauTo >= 4 * std::sqrt(mo.m2)) {
      set.patch.push_back(all.patch[m]);
      set.scale.push_back(all.scale[m]);
    }
  }
  return set;
}

// The pooled skewness of the patches of `set` numbered `members` read through `to_linear`:
// the sum of their third moments over the sum of their second moments to the power 1.5. Zero
// for point-symmetric edges. Pooled rather than the mean of each patch's skewness because a
// ratio of one patch's noisy moments is biased where its third and second moments share noise
// of one sign (shot noise, larger on the bright side): the pooled sum's sign is that of the
// summed third moments alone. *used counts the patches with enough contrast.
double PooledSkewness(const PatchSet& set, const std::vector<size_t>& members,
                      const std::function<double(double)>& to_linear, int* used) {
  const auto tables = Tables(set, to_linear);
  double sum3 = 0, sum2 = 0;
  *used = 0;
  std::vector<double> v;
  for (size_t m : members) {
    const Moments mo = PatchMoments(*set.patch[m], tables[static_cast<size_t>(set.scale[m])], &v);
    if (!mo.ok) continue;
    sum3 += mo.m3;
    sum2 += std::pow(mo.m2, 1.5);
    ++*used;
  }
  return sum2 > 0 ? sum3 / sum2 : 0;
}

// The gamma in [0.5, 3.5] at which the pooled skewness first crosses zero from above (it falls
// as gamma grows, a higher gamma darkening the foot of the rise more than its shoulder, until
// far beyond the truth the plateaus' normalisation turns it again): a scan in steps of 0.05,
// then regula falsi (Illinois) to 1e-4. Without a crossing, a small subset's curve may only
// touch zero (noise lifts its minimum a little above): then the gamma of least skewness, if
// that lies inside the scan and the skewness varies along it at least 10 times its least value.
// NaN otherwise: binary edges (printed artwork at its own resolution) read alike through any
// gamma, and a curve beyond the scan has its least value at an end.
double BestGamma(const PatchSet& set, const std::vector<size_t>& members) {
  int used = 0;
  auto skew = [&](double g) {
    return PooledSkewness(
        set, members, [g](double v) { return std::pow(v, g); }, &used);
  };
  double prev_g = 0.5, prev = skew(prev_g);
  double least = std::abs(prev), least_g = prev_g, lowest = prev, highest = prev;
  for (double g = 0.55; g <= 3.5 + 1e-9; g += 0.05) {
    const double s = skew(g);
    if (std::abs(s) < least) least = std::abs(s), least_g = g;
    lowest = std::min(lowest, s), highest = std::max(highest, s);
    if (prev > 0 && s <= 0) {
      double lo = prev_g, f_lo = prev, hi = g, f_hi = s;
      int side = 0;
      for (int iteration = 0; iteration < 40 && hi - lo > 1e-4; ++iteration) {
        const double mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        const double f = skew(mid);
        if (f > 0) {
          lo = mid, f_lo = f;
          if (side == 1) f_hi /= 2;
          side = 1;
        } else {
          hi = mid, f_hi = f;
          if (side == -1) f_lo /= 2;
          side = -1;
        }
        if (f == 0) return mid;
      }
      return 0.5 * (lo + hi);
    }
    prev_g = g, prev = s;
  }
  const bool interior = least_g > 0.5 + 1e-9 && least_g < 3.5 - 1e-9;
  return interior && highest - lowest >= 10 * least ? least_g : NAN;
}

}  // namespace

ResponseEstimate EstimateGammaFromEdges(const std::vector<EdgePatch>& patches) {
  ResponseEstimate out;
  const PatchSet set = Prepare(patches);
  std::vector<size_t> all(set.patch.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  int used = 0;
  PooledSkewness(
      set, all, [](double v) { return v; }, &used);
  if (used < 20) return out;
  const double best = BestGamma(set, all);
  if (!std::isfinite(best)) return out;
  out.gamma = best;
  out.patches = used;
  // The standard error: the spread of the estimates over 8 groups of the markers (a side's
  // patches overlap, so they go to one group; a marker's four sides, each printed side in every
  // group, too).
  constexpr int kGroups = 8;
  std::vector<double> g(kGroups);
  for (int k = 0; k < kGroups; ++k) {
    std::vector<size_t> part;
    for (size_t i = 0; i < all.size(); ++i)
      if (set.patch[i]->side / 4 % kGroups == static_cast<uint32_t>(k)) part.push_back(i);
    g[static_cast<size_t>(k)] = BestGamma(set, part);
  }
  // A group without an estimate counts as the scan's end it lies beyond.
  double mean = 0, var = 0;
  for (double& x : g)
    if (!std::isfinite(x)) x = best < 2 ? 0.5 : 3.5;
  for (double x : g) mean += x / kGroups;
  for (double x : g) var += (x - mean) * (x - mean) / (kGroups - 1);
  // Not below the root finding's and the groups' own resolution.
  out.sigma = std::max(std::sqrt(var / kGroups), 0.001);
  const double g_best = out.gamma;
  out.asymmetry = std::abs(PooledSkewness(
      set, all, [g_best](double v) { return std::pow(v, g_best); }, &used));
  out.asymmetry_linear = std::abs(PooledSkewness(
      set, all, [](double v) { return v; }, &used));
  const Response srgb = Response::Srgb();
  out.asymmetry_srgb = std::abs(PooledSkewness(
      set, all, [&srgb](double v) { return srgb.ToLinear(v); }, &used));
  return out;
}

void KeepEvenly(size_t keep, std::vector<EdgePatch>* patches) {
  const size_t n = patches->size();
  if (keep >= n) return;
  // Patch k * n / keep to slot k: the sources rise faster than the slots, so none is
  // overwritten before it is read.
  for (size_t k = 0; k < keep; ++k)
    if (const size_t from = k * n / keep; from != k) (*patches)[k] = std::move((*patches)[from]);
  patches->resize(keep);
}

}  // namespace svms
