#include "svms/detect/ring_equalizer.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "svms/codec/svms44.h"

namespace svms {
namespace {

constexpr int kCells = Svms44::kBits;

int Bit(uint64_t word, int i) { return static_cast<int>((word >> ((i + kCells) % kCells)) & 1); }

bool IsCorner(int i) { return i % Svms44::kBitsPerSide == 0; }

// The model's prediction of cell i's margin from its own bit and its neighbours'.
double Predict(const RingEqualization& m, int i, int prev, int self, int next) {
  double v = m.offset + m.gain * self + m.leak * (prev + next);
  if (IsCorner(i)) v += m.corner_offset + m.corner_gain * self;
  return v;
}

// Least squares of the model over the ring read as `word`; false where its regressors are
// collinear (all cells alike, or the neighbours' sum an affine function of the cell's own bit,
// as on a ring of period 4: 0011...), or where white does not read whiter than black. The
// corner cells' gain is fitted only where they are not all alike.
bool FitModel(const std::array<float, 44>& margin, uint64_t word, RingEqualization* out) {
  int corner_ones = 0;
  for (int i = 0; i < kCells; i += Svms44::kBitsPerSide) corner_ones += Bit(word, i);
  const bool corner_gain = corner_ones != 0 && corner_ones != 4;
  Eigen::Matrix<double, 5, 5> normal = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> rhs = Eigen::Matrix<double, 5, 1>::Zero();
  for (int i = 0; i < kCells; ++i) {
    const double c = IsCorner(i) ? 1 : 0, self = Bit(word, i);
    const Eigen::Matrix<double, 5, 1> x(1, self, Bit(word, i - 1) + Bit(word, i + 1), c, c * self);
    normal.selfadjointView<Eigen::Lower>().rankUpdate(x);
    rhs += x * margin[i];
  }
  normal.triangularView<Eigen::StrictlyUpper>() = normal.transpose();
  // Without the corner gain: its row and column replaced by the identity's, and its
  // right-hand side by 0, so that it solves to 0.
  if (!corner_gain) {
    normal.row(4).setZero();
    normal.col(4).setZero();
    normal(4, 4) = 1;
    rhs(4) = 0;
  }
  // The normal matrix holds small integers (counts), so its determinant is an integer: 0 where
  // the regressors are collinear, at least 1 otherwise.
  if (!(std::abs(normal.determinant()) > 0.5)) return false;
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(normal);
  const Eigen::Matrix<double, 5, 1> p = ldlt.solve(rhs);
  out->offset = p(0);
  out->gain = p(1);
  out->leak = p(2);
  out->corner_offset = p(3);
  out->corner_gain = p(4);
  double ss = 0;
  for (int i = 0; i < kCells; ++i) {
    const double e = margin[i] - Predict(*out, i, Bit(word, i - 1), Bit(word, i), Bit(word, i + 1));
    ss += e * e;
  }
  out->sum_of_squares = ss;
  out->residual_rms = std::sqrt(ss / (kCells - (corner_gain ? 5 : 4)));
  return std::isfinite(ss) && out->gain > 0 && out->gain + out->corner_gain > 0;
}

// The cyclic sequence of 44 bits with the least squared residuals under the model: a Viterbi
// search whose state is a pair of neighbouring bits (each cell's prediction needs both its
// neighbours), run once for each pair (s_43, s_0) the cycle starts from.
uint64_t MostLikelyRing(const std::array<float, 44>& margin, const RingEqualization& model) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // cell_cost[i][(prev << 2) | (self << 1) | next]: cell i's squared residual.
  double cell_cost[kCells][8];
  for (int i = 0; i < kCells; ++i) {
    for (int k = 0; k < 8; ++k) {
      const double e = margin[i] - Predict(model, i, k >> 2, (k >> 1) & 1, k & 1);
      cell_cost[i][k] = e * e;
    }
  }
  double best = kInf;
  uint64_t best_word = 0;
  uint8_t back[kCells][4];
  for (int start = 0; start < 4; ++start) {  // start = (s_43 << 1) | s_0
    // cost[state]: the least sum over cells 0..i-1 ending in state (s_{i-1} << 1) | s_i.
    double cost[4] = {kInf, kInf, kInf, kInf};
    cost[start] = 0;
    for (int i = 0; i + 1 < kCells; ++i) {  // cell i's residual once s_{i+1} is chosen
      double next_cost[4] = {kInf, kInf, kInf, kInf};
      for (int state = 0; state < 4; ++state) {
        if (cost[state] == kInf) continue;
        for (int next = 0; next < 2; ++next) {
          const int to = ((state & 1) << 1) | next;
          const double c = cost[state] + cell_cost[i][(state << 1) | next];
          if (c < next_cost[to]) {
            next_cost[to] = c;
            back[i + 1][to] = static_cast<uint8_t>(state);
          }
        }
      }
      for (int state = 0; state < 4; ++state) cost[state] = next_cost[state];
    }
    // Close the cycle: s_43 must be the start's, and cell 43 sees s_0 as its next.
    for (int state = 0; state < 4; ++state) {
      if (cost[state] == kInf || (state & 1) != (start >> 1)) continue;
      const double c = cost[state] + cell_cost[kCells - 1][(state << 1) | (start & 1)];
      if (c >= best) continue;
      best = c;
      uint64_t word = static_cast<uint64_t>(start & 1);
      int s = state;
      for (int i = kCells - 1; i >= 1; --i) {
        if (s & 1) word |= uint64_t{1} << i;
        s = back[i][s];
      }
      best_word = word;
    }
  }
  return best_word;
}

// From the reading `word`: fit, then search, until the reading settles (at most `rounds`).
RingEqualization Settle(const std::array<float, 44>& margin, uint64_t word, int rounds) {
  RingEqualization eq;
  if (!FitModel(margin, word, &eq)) return eq;
  eq.word = word;
  eq.ok = true;
  for (int round = 0; round < rounds; ++round) {
    const uint64_t next = MostLikelyRing(margin, eq);
    if (next == word) {
      eq.settled = true;
      break;
    }
    RingEqualization refit;
    if (!FitModel(margin, next, &refit)) break;  // keep the last reading the model held for
    word = next;
    eq = refit;
    eq.word = word;
    eq.ok = true;
  }
  return eq;
}

}  // namespace

RingEqualization EqualizeRing(const BitReading& reading, const RingEqualizerOptions& options) {
  // Starting readings: the plain one, and thresholds at quantiles of the margins (a ring read
  // mostly dark or light by the plain threshold starts the fit far from its model).
  std::array<float, 44> sorted = reading.margin;
  std::sort(sorted.begin(), sorted.end());
  std::array<uint64_t, 1 + RingEqualizerOptions::kMaxStarts> starts{};
  int count = 0;
  starts[count++] = reading.word;
  for (int k = 0; k < std::min(options.quantile_starts, RingEqualizerOptions::kMaxStarts); ++k) {
    const double q =
        options.quantile_starts == 1 ? 0.5 : 0.3 + 0.4 * k / (options.quantile_starts - 1);
    const float t = sorted[static_cast<int>(std::lround(q * (kCells - 1)))];
    uint64_t w = 0;
    for (int i = 0; i < kCells; ++i)
      if (reading.margin[i] > t) w |= uint64_t{1} << i;
    if (std::find(starts.begin(), starts.begin() + count, w) == starts.begin() + count)
      starts[count++] = w;
  }
  RingEqualization best;
  for (int k = 0; k < count; ++k) {
    const RingEqualization eq = Settle(reading.margin, starts[k], options.rounds);
    if (eq.ok && (!best.ok || eq.sum_of_squares < best.sum_of_squares)) best = eq;
  }
  return best;
}

}  // namespace svms
