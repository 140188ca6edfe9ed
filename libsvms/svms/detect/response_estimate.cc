#include "svms/detect/response_estimate.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <utility>

#include "svms/camera/photometric.h"

namespace svms {

void CollectEdgeProfiles(const cv::Mat& stored, const std::vector<Detection>& detections,
                         double black_level, double white_level, std::vector<EdgeProfile>* out,
                         size_t max_profiles) {
  if (stored.empty() || stored.channels() != 1 ||
      (stored.depth() != CV_8U && stored.depth() != CV_16U))
    return;
  const double white = white_level > 0 ? white_level : (stored.depth() == CV_8U ? 255 : 65535);
  const double range = white - black_level;
  if (!(range > 0)) return;
  constexpr int kHalf = kProfileSamples / 2;
  for (const Detection& d : detections) {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& c : d.corners) centre += 0.25 * c;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = d.corners[k], b = d.corners[(k + 1) % 4];
      const double length = (b - a).norm();
      // The white stripe is a third of the square's side wide: at least 4 px for +-3 px.
      if (!(length / 3 >= 4)) continue;
      const Eigen::Vector2d along = (b - a) / length;
      Eigen::Vector2d outward(-along.y(), along.x());
      if (outward.dot(0.5 * (a + b) - centre) < 0) outward = -outward;
      // The lines of a profile, min(1 px, 5 % of the side) apart and so spanning at most 4 px
      // along the side: straight enough over that stretch. The profiles sit in the middle half
      // of the side, so that the outer lines stay 15 % of the side from its corners, beyond the
      // other side's blur.
      const double spacing = std::min(1.0, 0.05 * length);
      for (double u : {0.25, 0.375, 0.5, 0.625, 0.75}) {
        if (out->size() >= max_profiles) return;
        EdgeProfile prof;
        prof.black = static_cast<float>(black_level);
        prof.range = static_cast<float>(range);
        bool inside = true;
        for (int line = 0; line < kProfileLines && inside; ++line) {
          const Eigen::Vector2d p = a + u * (b - a) + (line - kProfileLines / 2) * spacing * along;
          for (int i = 0; i < kProfileSamples && inside; ++i) {
            const Eigen::Vector2d q = p + (i - kHalf) * kProfileStep * outward;
            inside = q.x() >= 0 && q.y() >= 0 && q.x() < stored.cols - 2 && q.y() < stored.rows - 2;
            if (!inside) break;
            const int x0 = static_cast<int>(q.x()), y0 = static_cast<int>(q.y());
            const double fx = q.x() - x0, fy = q.y() - y0;
            const int xs[4] = {x0, x0 + 1, x0, x0 + 1}, ys[4] = {y0, y0, y0 + 1, y0 + 1};
            const double ws[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
            for (int k = 0; k < 4; ++k) {
              const uint16_t v = stored.depth() == CV_8U ? stored.at<uint8_t>(ys[k], xs[k])
                                                         : stored.at<uint16_t>(ys[k], xs[k]);
              prof.code[i][4 * line + k] = v;
              prof.weight[i][4 * line + k] = static_cast<float>(ws[k] / kProfileLines);
            }
          }
        }
        if (inside) out->push_back(prof);
      }
    }
  }
}

namespace {

// The skewness of the profiles' line spread functions (the derivative of each profile read
// through `to_linear`, normalised between its plateaus), over +-2 px about each one's mean,
// pooled: the sum of their third moments over the sum of their second moments to the power
// 1.5. Zero for point-symmetric edges. Pooled rather than the mean of each profile's
// skewness because a ratio of one profile's noisy moments is biased where its third and
// second moments share noise of one sign (shot noise, larger on the bright side): the pooled
// sum's sign is that of the summed third moments alone. Moments of the sampled derivative are
// sums over evenly spaced samples, so the place of the edge between samples does not bias
// them (a symmetry test that interpolates between samples does: its own error is larger than
// the effect of the curve). Profiles with too little contrast are skipped (*used counts the
// rest).
// The profiles with the scale each is read on ((code - black) / range), and each scale's
// largest code: found once for all the candidate curves.
struct ProfileSet {
  std::vector<const EdgeProfile*> profile;
  std::vector<int> scale;                       // per profile, an index into `scales`
  std::vector<std::pair<float, float>> scales;  // (black, range)
  std::vector<size_t> codes;                    // per scale, the largest code + 1
};

ProfileSet Prepare(const std::vector<EdgeProfile>& profiles) {
  ProfileSet set;
  std::map<std::pair<float, float>, int> index;
  for (const EdgeProfile& p : profiles) {
    const auto [it, added] =
        index.emplace(std::pair{p.black, p.range}, static_cast<int>(set.scales.size()));
    if (added) set.scales.push_back(it->first), set.codes.push_back(0);
    uint16_t top = 0;
    for (const auto& sample : p.code)
      top = std::max(top, *std::max_element(sample.begin(), sample.end()));
    set.codes[it->second] = std::max(set.codes[it->second], static_cast<size_t>(top) + 1);
    set.profile.push_back(&p);
    set.scale.push_back(it->second);
  }
  return set;
}

// The profiles of `set` numbered `members`.
double PooledSkewness(const ProfileSet& set, const std::vector<size_t>& members,
                      const std::function<double(double)>& to_linear, int* used) {
  constexpr int kN = kProfileSamples;
  double sum3 = 0, sum2 = 0;
  *used = 0;
  std::array<double, kN> n;
  // The curve read once per code of each scale: a profile reads 500 pixels per curve.
  std::vector<std::vector<double>> tables(set.scales.size());
  for (size_t s = 0; s < tables.size(); ++s) {
    const auto [black, range] = set.scales[s];
    tables[s].resize(set.codes[s]);
    for (size_t c = 0; c < tables[s].size(); ++c)
      tables[s][c] = to_linear(std::clamp((static_cast<float>(c) - black) / range, 0.0f, 1.0f));
  }
  for (size_t m : members) {
    const EdgeProfile* p = set.profile[m];
    const std::vector<double>& lut = tables[static_cast<size_t>(set.scale[m])];
    for (int i = 0; i < kN; ++i) {
      double v = 0;
      for (int k = 0; k < kProfilePixels; ++k) v += p->weight[i][k] * lut[p->code[i][k]];
      n[i] = v;
    }
    double dark = 0, bright = 0;
    for (int i = 0; i < 4; ++i) dark += n[i] / 4, bright += n[kN - 1 - i] / 4;
    if (!(bright - dark > 0.05)) continue;
    // The derivative's moments under a Gaussian taper of 1.5 px about its mean (iterated):
    // a hard window would jump as the mean moves and make the skewness a jagged function of
    // gamma.
    std::array<double, kN - 1> w;
    double w0 = 0, mean = 0;
    for (int i = 0; i + 1 < kN; ++i) {
      w[i] = (n[i + 1] - n[i]) / (bright - dark);
      w0 += w[i], mean += w[i] * (i + 0.5);
    }
    if (!(w0 > 0.5)) continue;
    mean /= w0;
    constexpr double kTaper = 6;  // samples (1.5 px)
    double m2 = 0, m3 = 0;
    for (int iteration = 0; iteration < 4; ++iteration) {
      double g0 = 0, g1 = 0, g2 = 0, g3 = 0;
      for (int i = 0; i + 1 < kN; ++i) {
        const double x = i + 0.5 - mean;
        const double g = w[i] * std::exp(-x * x / (2 * kTaper * kTaper));
        g0 += g, g1 += g * x, g2 += g * x * x, g3 += g * x * x * x;
      }
      if (!(g0 > 0)) break;
      if (iteration < 3) {
        mean += g1 / g0;
      } else {
        m2 = g2 / g0, m3 = g3 / g0;
      }
    }
    if (!(m2 > 0)) continue;
    sum3 += m3;
    sum2 += std::pow(m2, 1.5);
    ++*used;
  }
  return sum2 > 0 ? sum3 / sum2 : 0;
}

// The gamma in [0.5, 3.5] at which the pooled skewness first crosses zero from above (it falls
// as gamma grows, a higher gamma darkening the foot of the rise more than its shoulder, until
// far beyond the truth the plateaus' normalisation turns it again): a scan in steps of 0.05,
// then bisection to 1e-4. Without a crossing, a small subset's curve may only touch zero
// (noise lifts its minimum a little above): then the gamma of least skewness, if that lies
// inside the scan and the skewness varies along it at least 10 times its least value. NaN
// otherwise: binary edges (printed artwork at its own resolution) read alike through any
// gamma, and a curve beyond the scan has its least value at an end.
double BestGamma(const ProfileSet& set, const std::vector<size_t>& members) {
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
      double lo = prev_g, hi = g;
      while (hi - lo > 1e-4) {
        const double mid = 0.5 * (lo + hi);
        (skew(mid) > 0 ? lo : hi) = mid;
      }
      return 0.5 * (lo + hi);
    }
    prev_g = g, prev = s;
  }
  const bool interior = least_g > 0.5 + 1e-9 && least_g < 3.5 - 1e-9;
  return interior && highest - lowest >= 10 * least ? least_g : NAN;
}

}  // namespace

ResponseEstimate EstimateGammaFromEdges(const std::vector<EdgeProfile>& profiles) {
  ResponseEstimate out;
  const ProfileSet set = Prepare(profiles);
  std::vector<size_t> all(profiles.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  int used = 0;
  PooledSkewness(
      set, all, [](double v) { return v; }, &used);
  if (used < 20) return out;
  const double best = BestGamma(set, all);
  if (!std::isfinite(best)) return out;
  out.gamma = best;
  out.profiles = used;
  // The standard error: the spread of the estimates over 8 groups of the profiles.
  constexpr int kGroups = 8;
  std::vector<double> g(kGroups);
  for (int k = 0; k < kGroups; ++k) {
    std::vector<size_t> part;
    for (size_t i = static_cast<size_t>(k); i < all.size(); i += kGroups) part.push_back(i);
    g[static_cast<size_t>(k)] = BestGamma(set, part);
  }
  // A group without an estimate counts as the scan's end it lies beyond.
  double mean = 0, var = 0;
  for (double& x : g)
    if (!std::isfinite(x)) x = best < 2 ? 0.5 : 3.5;
  for (double x : g) mean += x / kGroups;
  for (double x : g) var += (x - mean) * (x - mean) / (kGroups - 1);
  // Not below the bisection's and the groups' own resolution.
  out.sigma = std::max(std::sqrt(var / kGroups), 0.01);
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

}  // namespace svms
