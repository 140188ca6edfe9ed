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

constexpr int kBins = 24;           // uniform in sqrt((level - black) / (full - black))
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

// The codes of a 16-bit image (a ladder): an 8-bit sRGB or gamma-encoded image turned into
// linear light takes only the 256 values its codes map to, 20 units apart in the darks and 400
// in the brights; raw 12-bit data scaled to 16 bits are 16 apart; genuinely 16-bit data use
// every value. The noise is measured on the codes' ranks, where the rounding is 1/12 of a code
// squared at every level and the integer quantile below is exact, then brought back to linear
// units by the ladder's step there. (Measured on the linear values directly, the rounding to
// 400-unit codes at mid grey reads as half the shot noise it is.)
struct Ladder {
  std::vector<uint16_t> code;  // rank of each value among the values seen
  std::vector<float> step;     // linear units per code at each value seen
};

// Calls visit(centre, left, right, up, down) with the values of every sample's five pixels in
// row y (the pixels Sample reads).
template <typename Visit>
void ForEachSample(const cv::Mat& img, int y, const Visit& visit) {
  const uint16_t *up = img.ptr<uint16_t>(y - 1), *row = img.ptr<uint16_t>(y),
                 *down = img.ptr<uint16_t>(y + 1);
  for (int x = 1 + (y / kStride) % kStride; x + 1 < img.cols; x += kStride)
    visit(row[x], row[x - 1], row[x + 1], up[x], down[x]);
}

// False when `deadline` (read every 64 rows) passed. *is_ladder is false where at least a tenth
// of the values seen have their next value seen too: data that use every value where the
// light is (16 bits of signal), measured on the values themselves; ranks would only compress
// their sparsely sampled tails. A ladder's codes are 2 or more apart
// (16 for 12-bit raw data in 16 bits).
bool MakeLadder(const cv::Mat& img, Ladder* ladder, bool* is_ladder, Clock::time_point deadline) {
  thread_local std::vector<uint8_t> used;
  used.assign(65536, 0);
  uint8_t* u = used.data();
  for (int y = 1; y + 1 < img.rows; y += kStride) {
    if ((y / kStride) % 16 == 15 && Past(deadline)) return false;
    ForEachSample(img, y,
                  [u](int v, int a, int b, int c, int d) { u[v] = u[a] = u[b] = u[c] = u[d] = 1; });
  }
  ladder->code.resize(65536);
  ladder->step.resize(65536);
  thread_local std::vector<int> seen;
  seen.clear();
  int rank = 0, adjacent = 0;
  for (int v = 0; v < 65536; ++v) {
    ladder->code[static_cast<size_t>(v)] = static_cast<uint16_t>(rank);
    if (!u[v]) continue;
    ++rank;
    adjacent += v + 1 < 65536 && u[v + 1];
    seen.push_back(v);
  }
  // A value's step: the mean of the gaps between seen values over the kStepRanks ranks either
  // side, leaving out gaps over 2.5 times the smallest of them (a jump between two separate
  // brightness levels of the scene, whose codes in between no pixel took). The noise spans
  // several codes, so what turns it from ranks into linear units is the mean gap there, codes
  // in reach of the noise that were never used included (a levels stretch's combed histogram:
  // 1.5 codes per rank); a tone curve's ladder changes slowly over 2 x kStepRanks codes.
  constexpr int kStepRanks = 2;
  const int n = static_cast<int>(seen.size());
  for (int k = 0; k < n; ++k) {
    const int lo = std::max(0, k - kStepRanks), hi = std::min(n - 1, k + kStepRanks);
    int smallest = 65536;
    for (int j = lo; j < hi; ++j) smallest = std::min(smallest, seen[j + 1] - seen[j]);
    double sum = 0;
    int count = 0;
    for (int j = lo; j < hi; ++j)
      if (const int gap = seen[j + 1] - seen[j]; gap <= 2.5 * smallest) sum += gap, ++count;
    ladder->step[static_cast<size_t>(seen[k])] = count > 0 ? static_cast<float>(sum / count) : 1.0f;
  }
  *is_ladder = 10 * adjacent < rank;
  return true;
}

// False when `deadline` (read every 64 rows) passed. With `ladder` (16-bit images), the
// Laplacian is taken on the codes and each bin's step^2 summed into *step2_sum.
template <typename T>
bool Sample(const cv::Mat& img, int black, int full, const Ladder* ladder,
            std::array<std::vector<int>, kBins>* r, std::array<double, kBins>* level_sum,
            std::array<double, kBins>* step2_sum, Clock::time_point deadline) {
  // The bin of a level, uniform in sqrt((level - black) / (full - black)) (bin 0 below black),
  // from a table over level / 16.
  thread_local std::vector<uint8_t> bin_of;
  const int shift = full > 255 ? 4 : 0;
  bin_of.resize(static_cast<size_t>((full >> shift) + 1));
  for (size_t i = 0; i < bin_of.size(); ++i) {
    const double above = std::max(0, static_cast<int>(i << shift) - black);
    bin_of[i] = static_cast<uint8_t>(
        std::min(kBins - 1, static_cast<int>(kBins * std::sqrt(above / (full - black)))));
  }
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
      (*level_sum)[bin] += sum / 5.0;
      if (ladder) {
        const uint16_t* k = ladder->code.data();
        (*r)[bin].push_back(std::abs(4 * k[v] - k[a] - k[b] - k[c] - k[d]));
        const double st = ladder->step[static_cast<size_t>(v)];
        (*step2_sum)[bin] += st * st;
      } else {
        (*r)[bin].push_back(std::abs(4 * v - a - b - c - d));
      }
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

namespace {

// EstimateNoise, with the levels measured from `black` (the stored frame's zero; 0 for a linear
// image) and `white` the saturation (0: the depth's largest value), which also sets the bins.
// The clip at 0 is what it is in either case: a sample with a 0 among its pixels is left out,
// and so is a bin whose mean is within 3 sigmas of 0.
bool EstimateNoiseFrom(const cv::Mat& img, double black, double white, Clock::time_point deadline,
                       NoiseModel* noise) {
  NoiseModel& out = *noise;
  out = NoiseModel();
  if (img.rows < 8 || img.cols < 8 || (img.type() != CV_8UC1 && img.type() != CV_16UC1))
    return true;
  const bool eight = img.depth() == CV_8U;
  const int depth_max = eight ? 255 : 65535;
  const int full =
      white > 0 ? std::min(depth_max, static_cast<int>(std::lround(white))) : depth_max;
  thread_local std::array<std::vector<int>, kBins> r;
  thread_local Ladder ladder;
  std::array<double, kBins> level_sum{}, step2_sum{};
  for (auto& v : r) v.clear();
  bool is_ladder = false;
  if (!eight && !MakeLadder(img, &ladder, &is_ladder, deadline)) return false;
  const int black_code = std::clamp(static_cast<int>(std::lround(black)), 0, full - 1);
  if (!(eight
            ? Sample<uint8_t>(img, black_code, full, nullptr, &r, &level_sum, &step2_sum, deadline)
            : Sample<uint16_t>(img, black_code, full, is_ladder ? &ladder : nullptr, &r, &level_sum,
                               &step2_sum, deadline)))
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
  int hidden_bins = 0, hidden_samples = 0, seen_samples = 0;
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
    // Sigma in codes (8 bits: levels), and the codes' rounding, 1/12 of a code squared.
    const double sigma_code = std::max(quantile, 0.0) * kQuantileToSigma;
    // Where the noise is below about a code's step the codes hide it (a flat patch all one
    // code reads as noiseless): such a bin says nothing of the noise.
    if (sigma_code * sigma_code < 2.0 / 12) {
      ++hidden_bins;
      hidden_samples += n;
      continue;
    }
    // Linear units per code squared: 1 for 8 bits, the ladder's step^2 over the bin's samples.
    const double step2 = is_ladder ? step2_sum[b] / n : 1.0;
    const double sigma = sigma_code * std::sqrt(step2);
    const double stored_level = level_sum[b] / n;
    if (stored_level < 3 * sigma) continue;  // too near the clip at 0 to show its full spread
    const double level = stored_level - black;
    const double var = (sigma_code * sigma_code - 1.0 / 12) * step2;
    // A variance estimate from n samples has a relative sigma of about sqrt(2 / n) (more for a
    // quantile); weight by its inverse variance.
    const double s2 = std::max(var, 1e-6 * full);
    bins.push_back({level, var, n / (s2 * s2)});
    seen_samples += n;
  }
  // Most samples where the codes hide the noise: the image has less noise than its codes'
  // steps (a JPEG's codec smooths the flat areas away), and the few bins left are edges and
  // texture. No noise is reported: read and gain 0 on the hidden bins (valid, nothing to
  // stabilise).
  if (hidden_samples > seen_samples) {
    out.bins = hidden_bins;
    return true;
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

}  // namespace

bool EstimateNoise(const cv::Mat& img, Clock::time_point deadline, NoiseModel* noise) {
  return EstimateNoiseFrom(img, 0, 0, deadline, noise);
}

bool EstimateStoredNoise(const cv::Mat& stored, const PhotometricModel& model,
                         Clock::time_point deadline, NoiseModel* linear_noise) {
  if (stored.channels() != 1 || (stored.depth() != CV_8U && stored.depth() != CV_16U) ||
      model.bayer != BayerPattern::kNone || model.response.kind() != Response::Kind::kLinear ||
      !(model.black_level > 0))
    return false;
  const double depth_max = stored.depth() == CV_8U ? 255.0 : 65535.0;
  const double white = model.white_level > 0 ? std::floor(model.white_level) : depth_max;
  if (!(white > model.black_level) || white > depth_max) return false;  // as the Linearizer
  // The values of every 4th pixel of every 4th row below the black level and at it. A frame
  // clipped at its black level (some cameras do; a few dead pixels may still lie below) has
  // its dark values at black and holds no more than its linear image: where fewer than 16 lie
  // below black, or fewer than half as many as at it, it is not measured here.
  const int black = static_cast<int>(std::ceil(model.black_level));
  int below = 0, at_black = 0;
  for (int y = 0; y < stored.rows; y += kStride) {
    if (stored.depth() == CV_8U) {
      const uint8_t* p = stored.ptr<uint8_t>(y);
      for (int x = 0; x < stored.cols; x += kStride)
        below += p[x] < black, at_black += p[x] == black;
    } else {
      const uint16_t* p = stored.ptr<uint16_t>(y);
      for (int x = 0; x < stored.cols; x += kStride)
        below += p[x] < black, at_black += p[x] == black;
    }
  }
  if (below < 16 || 2 * below < at_black) return false;
  NoiseModel noise;
  if (!EstimateNoiseFrom(stored, model.black_level, white, deadline, &noise)) return false;
  // The linear image is (stored - black) 65535 / (white - black) (Linearizer, photometric.h).
  *linear_noise = noise.Scaled(65535.0 / (white - model.black_level));
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
