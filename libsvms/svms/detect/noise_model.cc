#include "svms/detect/noise_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace svms {

double NoiseModel::Sigma(double level) const {
  return std::sqrt(std::max(0.0, read_sigma * read_sigma + shot_gain * std::max(level, 0.0)));
}

NoiseModel NoiseModel::Scaled(double k) const {
  NoiseModel m = *this;
  m.read_sigma *= k;
  m.shot_gain *= k;
  return m;
}

namespace {

constexpr int kBins = 24;           // uniform in sqrt(level / full)
constexpr int kMinSamples = 200;    // per bin
constexpr double kQuantile = 0.25;  // of |Laplacian|: texture and edges sit in the upper tail
// For white noise sigma, the Laplacian 4 v - (4 neighbours) has sigma sqrt(20) sigma, and the
// 25th percentile of a normal's absolute value is 0.3186 of its sigma.
constexpr double kQuantileToSigma = 1.0 / (0.3186 * 4.4721359549995796);

// Every 4th pixel of every 4th row (about 65,000 samples at 1024 x 1024: the fit needs a few
// hundred per bin).
constexpr int kStride = 4;

using Clock = std::chrono::steady_clock;

bool Past(Clock::time_point deadline) {
  return deadline != Clock::time_point::max() && Clock::now() >= deadline;
}

// False when `deadline` (read every 64 rows) passed.
template <typename T>
bool Sample(const cv::Mat& img, int full, std::array<std::vector<int>, kBins>* r,
            std::array<double, kBins>* level_sum, Clock::time_point deadline) {
  // The bin of a level, uniform in sqrt(level / full), from a table over level / 16.
  thread_local std::vector<uint8_t> bin_of;
  const int shift = full > 255 ? 4 : 0;
  bin_of.resize(static_cast<size_t>((full >> shift) + 1));
  for (size_t i = 0; i < bin_of.size(); ++i)
    bin_of[i] = static_cast<uint8_t>(std::min(
        kBins - 1, static_cast<int>(kBins * std::sqrt(static_cast<double>(i << shift) / full))));
  for (int y = 1; y + 1 < img.rows; y += kStride) {
    if ((y / kStride) % 16 == 15 && Past(deadline)) return false;
    const T *up = img.ptr<T>(y - 1), *row = img.ptr<T>(y), *down = img.ptr<T>(y + 1);
    for (int x = 1 + (y / kStride) % kStride; x + 1 < img.cols; x += kStride) {
      const int v = row[x], a = row[x - 1], b = row[x + 1], c = up[x], d = down[x];
      const int lo = std::min({v, a, b, c, d}), hi = std::max({v, a, b, c, d});
      if (lo <= 0 || hi >= full) continue;  // clipped: its spread is not the noise's
      // Binned by the mean of the five values, which for white noise is independent of the
      // Laplacian (their covariance is (4 - 4) sigma^2 / 5): binning by the centre value alone
      // would sort each flat patch's samples by their own noise and bias every bin.
      const int sum = v + a + b + c + d;
      const int bin = bin_of[static_cast<size_t>((sum / 5) >> shift)];
      (*r)[bin].push_back(std::abs(4 * v - a - b - c - d));
      (*level_sum)[bin] += sum / 5.0;
    }
  }
  return true;
}

}  // namespace

NoiseModel EstimateNoise(const cv::Mat& img) {
  NoiseModel out;
  EstimateNoise(img, Clock::time_point::max(), &out);
  return out;
}

bool EstimateNoise(const cv::Mat& img, Clock::time_point deadline, NoiseModel* noise) {
  NoiseModel& out = *noise;
  out = NoiseModel();
  if (img.rows < 8 || img.cols < 8 || (img.type() != CV_8UC1 && img.type() != CV_16UC1))
    return true;
  const bool eight = img.depth() == CV_8U;
  const int full = eight ? 255 : 65535;
  thread_local std::array<std::vector<int>, kBins> r;
  std::array<double, kBins> level_sum{};
  for (auto& v : r) v.clear();
  if (!(eight ? Sample<uint8_t>(img, full, &r, &level_sum, deadline)
              : Sample<uint16_t>(img, full, &r, &level_sum, deadline)))
    return false;
  // Per bin: its mean level and the noise variance from the quantile of |Laplacian|.
  struct Bin {
    double level, var, weight;
  };
  // Fixed-size storage: no allocation per frame (the detector's promise for 16-bit frames too).
  struct Bins {
    std::array<Bin, kBins> b;
    size_t n = 0;
    void push_back(const Bin& x) { b[n++] = x; }
    size_t size() const { return n; }
    bool empty() const { return n == 0; }
    const Bin* begin() const { return b.data(); }
    const Bin* end() const { return b.data() + n; }
  };
  Bins bins;
  const double quantisation = eight ? 1.0 / 12 : 0.0;
  for (int b = 0; b < kBins; ++b) {
    const int n = static_cast<int>(r[b].size());
    if (n < kMinSamples) continue;
    const double target = kQuantile * n;
    auto q = r[b].begin() + static_cast<long>(target);
    std::nth_element(r[b].begin(), q, r[b].end());
    // The values are integers: the quantile interpolated within the run of values equal to
    // it (otherwise 8-bit data, where it is a few levels, would be off by up to half a level).
    const int qv = *q;
    int below = 0, equal = 0;
    for (int v : r[b]) below += v < qv, equal += v == qv;
    const double quantile = qv - 0.5 + (target - below) / std::max(equal, 1);
    const double sigma = std::max(quantile, 0.0) * kQuantileToSigma;
    const double level = level_sum[b] / n;
    if (level < 3 * sigma) continue;  // too near the clip at 0 to show its full spread
    const double var = std::max(0.0, sigma * sigma - quantisation);
    // A variance estimate from n samples has a relative sigma of about sqrt(2 / n) (more for a
    // quantile); weight by its inverse variance.
    const double s2 = std::max(var, 1e-6 * full);
    bins.push_back({level, var, n / (s2 * s2)});
  }
  if (bins.empty()) return true;
  // var = a + g L, weighted least squares; a, g >= 0. Bins far above the fit (texture) are
  // dropped once.
  double a = 0, g = 0;
  auto fit = [&](const Bins& use) {
    double sw = 0, sl = 0, sv = 0, sll = 0, slv = 0;
    for (const Bin& b : use) {
      sw += b.weight, sl += b.weight * b.level, sv += b.weight * b.var;
      sll += b.weight * b.level * b.level, slv += b.weight * b.level * b.var;
    }
    const double det = sw * sll - sl * sl;
    if (use.size() >= 2 && det > 1e-12 * sw * sll) {
      g = (sw * slv - sl * sv) / det;
      a = (sv - g * sl) / sw;
    } else {
      g = 0, a = sv / sw;  // one level: all of it read noise (never amplifies the darks)
    }
    if (g < 0) g = 0, a = sv / sw;
    if (a < 0) a = 0, g = sll > 0 ? slv / sll : 0;
  };
  fit(bins);
  if (bins.size() >= 3) {
    Bins kept;
    for (const Bin& b : bins)
      if (b.var <= 2.0 * (a + g * b.level) + 1e-9) kept.push_back(b);
    if (kept.size() >= 2 && kept.size() < bins.size()) {
      fit(kept);
      bins = kept;
    }
  }
  out.read_sigma = std::sqrt(a);
  out.shot_gain = g;
  out.bins = static_cast<int>(bins.size());
  return true;
}

double StabiliseVariance(const cv::Mat& linear16, const NoiseModel& noise, cv::Mat* out8,
                         Clock::time_point deadline) {
  CV_Assert(linear16.type() == CV_16UC1);
  const double a = std::max(noise.read_sigma * noise.read_sigma, 1e-12), g = noise.shot_gain;
  auto T = [&](double L) {
    return g > 0 ? 2 / g * (std::sqrt(g * L + a) - std::sqrt(a)) : L / std::sqrt(a);
  };
  const double scale = 255 / std::max(T(65535), 1e-9);
  // The table is rebuilt only when the model changes (successive frames of one camera give
  // nearly the same estimate; a change under 1 % of the scale moves no value by half a level).
  thread_local std::vector<uint8_t> lut(65536);
  thread_local double lut_a = -1, lut_g = -1;
  if (std::abs(a - lut_a) > 0.01 * lut_a || std::abs(g - lut_g) > 0.01 * lut_g + 1e-12) {
    for (int v = 0; v < 65536; ++v)
      lut[static_cast<size_t>(v)] = cv::saturate_cast<uint8_t>(scale * T(v));
    lut_a = a, lut_g = g;
  }
  out8->create(linear16.size(), CV_8UC1);
  const uint8_t* __restrict table = lut.data();
  for (int y = 0; y < linear16.rows; ++y) {
    if (y % 64 == 63 && Past(deadline)) return 0;
    const uint16_t* __restrict in = linear16.ptr<uint16_t>(y);
    uint8_t* __restrict o = out8->ptr<uint8_t>(y);
    for (int x = 0; x < linear16.cols; ++x) o[x] = table[in[x]];
  }
  return scale;
}

}  // namespace svms
