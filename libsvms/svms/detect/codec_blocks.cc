#include "svms/detect/codec_blocks.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace svms {

SideBlocks SideBlockSums(const std::vector<Eigen::Vector2d>& px, const std::vector<double>& r,
                         const std::vector<char>& use, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b, std::vector<CodecBlock>* scratch) {
  SideBlocks out;
  const double len = (b - a).norm();
  if (!(len > 0)) return out;
  const Eigen::Vector2d u = (b - a) / len;
  auto counted = [&](size_t i) { return use[i] && px[i].allFinite() && std::isfinite(r[i]); };
  double mean = 0;
  for (size_t i = 0; i < px.size(); ++i)
    if (counted(i)) mean += u.dot(px[i] - a), ++out.n;
  if (out.n < 3) return SideBlocks{};
  mean /= out.n;
  std::vector<CodecBlock>& blocks = *scratch;
  blocks.clear();
  for (size_t i = 0; i < px.size(); ++i) {
    if (!counted(i)) continue;
    const int64_t key =
        static_cast<int64_t>(std::floor((px[i].y() + 0.5) / kCodecBlockPx)) * (int64_t{1} << 32) +
        static_cast<int64_t>(std::floor((px[i].x() + 0.5) / kCodecBlockPx));
    const double s = u.dot(px[i] - a) - mean;
    // The points come in order along the side, which crosses each block once: the last block
    // is nearly always the one.
    auto it = !blocks.empty() && blocks.back().key == key
                  ? blocks.end() - 1
                  : std::find_if(blocks.begin(), blocks.end(),
                                 [&](const CodecBlock& g) { return g.key == key; });
    if (it == blocks.end()) blocks.push_back({key, 0, 0, 0}), it = blocks.end() - 1;
    it->n += 1, it->t += s, it->r += r[i];
    out.S += s * s;
    out.q1 += r[i] * r[i];
  }
  if (!(out.S > 0)) return SideBlocks{};
  double in_h = 0;    // sum_g 1_g' H 1_g
  double diag_h = 0;  // sum_g n_g 1_g' H 1_g
  for (const CodecBlock& g : blocks) {
    const double h = g.n * g.n / out.n + g.t * g.t / out.S;
    in_h += h, diag_h += g.n * h;
    out.N2 += g.n * g.n, out.T2 += g.t * g.t, out.NT += g.n * g.t;
    out.q2 += g.r * g.r;
  }
  // tr(I - H) = n - 2; tr(J (I - H)) = sum n_g - sum_g 1_g' H 1_g; tr(J (I - H) J (I - H)) =
  // tr(J^2) - 2 tr(J H J) + tr(J H J H), with J^2 = sum_g n_g 1_g 1_g' and 1_g' H 1_h =
  // n_g n_h / n + t_g t_h / S.
  out.a1 = out.n - 2;
  out.c1 = out.a2 = out.n - in_h;
  out.c2 = out.N2 - 2 * diag_h + out.N2 * out.N2 / (out.n * out.n) +
           2 * out.NT * out.NT / (out.n * out.S) + out.T2 * out.T2 / (out.S * out.S);
  out.s0 = -mean;
  out.s1 = len - mean;
  return out;
}

Eigen::Vector2d BlockVariances(const std::array<SideBlocks, 4>& sides) {
  Eigen::Matrix2d M = Eigen::Matrix2d::Zero();
  Eigen::Vector2d q = Eigen::Vector2d::Zero();
  for (const SideBlocks& b : sides) {
    M += (Eigen::Matrix2d() << b.a1, b.c1, b.a2, b.c2).finished();
    q += Eigen::Vector2d(b.q1, b.q2);
  }
  if (!(M(0, 0) > 0) || !q.allFinite()) return Eigen::Vector2d::Zero();
  const double a0 = q(0) / M(0, 0);
  // Under c = 0, q2 - a0 a2 has mean 0 and variance 2 a^2 (c2 - c1^2 / a1) (a0 taken from the
  // same residuals); a1 c2 >= c1^2 always (Cauchy-Schwarz), with equality only where every
  // block holds one point, and then c cannot be told from a.
  // Where every side lies in one block each, c1 and c2 are 0 but for rounding and the blocks
  // cannot be told from the lines: the information on c must stand out of sum N2's rounding.
  double n2 = 0;
  for (const SideBlocks& b : sides) n2 += b.N2;
  const double information = M(1, 1) - M(0, 1) * M(0, 1) / M(0, 0);
  const double null_variance = 2 * a0 * a0 * information;
  if (!(information > 1e-9 * n2) || !(null_variance > 0) ||
      !(q(1) - a0 * M(1, 0) > 2 * std::sqrt(null_variance)))
    return Eigen::Vector2d(a0, 0);
  const Eigen::Vector2d ac = M.partialPivLu().solve(q);
  if (!ac.allFinite()) return Eigen::Vector2d(a0, 0);
  // Both shares positive, or the model is not taken: a <= 0 (all of the variance shared, or
  // more) is what a marker's few blocks give by chance far more often than a codec does, and
  // would make each side's two ends move as one (correlation 1, a singular covariance).
  if (!(ac.y() > 0) || !(ac.x() > 0)) return Eigen::Vector2d(a0, 0);
  return ac;
}

double SideLineEnds::Correlation() const { return ok ? covariance / std::sqrt(v0 * v1) : NAN; }

SideLineEnds SideLineVariance(const SideBlocks& b, const Eigen::Vector2d& ac) {
  SideLineEnds out;
  if (!(b.n >= 3 && b.S > 0 && b.a1 > 0)) return out;
  const double a = ac.x(), c = ac.y();
  // The line's place across itself at s: offset + s slope, both linear in the points' errors
  // with weights 1/n and s_i / S; under a I + c J their covariance at s and t:
  auto cov = [&](double s, double t) {
    return a * (1 / b.n + s * t / b.S) +
           c * (b.N2 / (b.n * b.n) + s * t * b.T2 / (b.S * b.S) + (s + t) * b.NT / (b.n * b.S));
  };
  out.v0 = cov(b.s0, b.s0);
  out.v1 = cov(b.s1, b.s1);
  out.covariance = cov(b.s0, b.s1);
  out.scatter = a + c * b.c1 / b.a1;
  out.ok = out.scatter > 0 && out.v0 > 0 && out.v1 > 0;
  if (!out.ok) return out;
  out.factor = 0.5 *
               (out.v0 / (1 / b.n + b.s0 * b.s0 / b.S) + out.v1 / (1 / b.n + b.s1 * b.s1 / b.S)) /
               out.scatter;
  return out;
}

}  // namespace svms
