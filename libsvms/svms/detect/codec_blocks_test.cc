#include "svms/detect/codec_blocks.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

namespace svms {
namespace {

// A side from a to b with a point every `step` px (from step / 2 on), all inliers.
std::vector<Eigen::Vector2d> PointsAlong(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                         double step) {
  std::vector<Eigen::Vector2d> px;
  const double len = (b - a).norm();
  for (double t = 0.5 * step; t < len; t += step) px.push_back(a + t / len * (b - a));
  return px;
}

int64_t BlockOf(const Eigen::Vector2d& p) {
  return static_cast<int64_t>(std::floor((p.y() + 0.5) / kCodecBlockPx)) * 100000 +
         static_cast<int64_t>(std::floor((p.x() + 0.5) / kCodecBlockPx));
}

// The side's hat matrix H (ordinary line fit in the places s along it) and block matrix J,
// over the points `px` (all inliers).
void Explicit(const std::vector<Eigen::Vector2d>& px, const Eigen::Vector2d& a,
              const Eigen::Vector2d& b, Eigen::MatrixXd* H, Eigen::MatrixXd* J) {
  const int n = static_cast<int>(px.size());
  const Eigen::Vector2d u = (b - a).normalized();
  Eigen::MatrixXd X(n, 2);
  for (int i = 0; i < n; ++i) X(i, 0) = 1, X(i, 1) = u.dot(px[i] - a);
  X.col(1).array() -= X.col(1).mean();
  *H = X * (X.transpose() * X).inverse() * X.transpose();
  J->resize(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) (*J)(i, j) = BlockOf(px[i]) == BlockOf(px[j]);
}

// Draws of per-point errors with covariance a I + c J.
Eigen::VectorXd DrawErrors(const std::vector<Eigen::Vector2d>& px, double a, double c,
                           std::mt19937& rng) {
  std::normal_distribution<double> normal(0, 1);
  std::map<int64_t, double> shared;
  Eigen::VectorXd e(px.size());
  for (size_t i = 0; i < px.size(); ++i) {
    auto it = shared.find(BlockOf(px[i]));
    if (it == shared.end()) it = shared.emplace(BlockOf(px[i]), normal(rng)).first;
    e(i) = std::sqrt(a) * normal(rng) + std::sqrt(c) * it->second;
  }
  return e;
}

std::vector<double> ToVector(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

// The sums' closed forms against the traces of explicit matrices, on sides at several angles
// and with left-out points.
TEST(SideBlockSums, TheClosedFormsAreTheTracesOfTheMatrices) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> where(5, 95), turn(0, 2 * M_PI);
  std::normal_distribution<double> normal(0, 0.3);
  std::vector<CodecBlock> scratch;
  for (int trial = 0; trial < 6; ++trial) {
    const double angle = turn(rng);
    const Eigen::Vector2d a(where(rng), where(rng));
    const Eigen::Vector2d b = a + 40 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    std::vector<Eigen::Vector2d> all = PointsAlong(a, b, 1.5);
    ASSERT_GE(all.size(), 10u);
    std::vector<char> use(all.size(), 1);
    use[2] = use[all.size() / 2] = 0;
    std::vector<double> r(all.size());
    for (double& v : r) v = normal(rng);
    std::vector<Eigen::Vector2d> in;
    std::vector<double> r_in;
    for (size_t i = 0; i < all.size(); ++i)
      if (use[i]) in.push_back(all[i]), r_in.push_back(r[i]);
    Eigen::MatrixXd H, J;
    Explicit(in, a, b, &H, &J);
    const int n = static_cast<int>(in.size());
    const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(n, n) - H;
    const Eigen::VectorXd rv = Eigen::Map<const Eigen::VectorXd>(r_in.data(), n);
    const SideBlocks s = SideBlockSums(all, r, use, a, b, &scratch);
    EXPECT_EQ(s.n, n);
    EXPECT_NEAR(s.a1, M.trace(), 1e-9);
    EXPECT_NEAR(s.c1, (J * M).trace(), 1e-9);
    EXPECT_EQ(s.a2, s.c1);
    EXPECT_NEAR(s.c2, (J * M * J * M).trace(), 1e-9 * s.c2);
    EXPECT_NEAR(s.q1, rv.squaredNorm(), 1e-9);
    EXPECT_NEAR(s.q2, rv.dot(J * rv), 1e-9);
  }
}

// Block g spans [8g - 0.5, 8g + 7.5): pixel centres at whole numbers (docs/conventions.md).
// Points at x = 0.5, 1.5, ..., 15.5 fall 7, 8 and 1 to a block (8 and 8 with the grid laid
// from the pixels' corner).
TEST(SideBlockSums, BlocksAreLaidFromThePixelCentres) {
  std::vector<Eigen::Vector2d> px;
  for (int i = 0; i < 16; ++i) px.emplace_back(i + 0.5, 3.0);
  std::vector<CodecBlock> scratch;
  const SideBlocks s = SideBlockSums(px, std::vector<double>(16, 0.1), std::vector<char>(16, 1),
                                     Eigen::Vector2d(0, 3), Eigen::Vector2d(16, 3), &scratch);
  EXPECT_EQ(s.N2, 7 * 7 + 8 * 8 + 1 * 1);
  EXPECT_EQ(scratch.size(), 3u);
}

TEST(SideBlockSums, TooFewPointsOrNonFiniteOnesGiveEmptySums) {
  std::vector<CodecBlock> scratch;
  const Eigen::Vector2d a(0, 0), b(10, 0);
  std::vector<Eigen::Vector2d> px = {{1, 0}, {2, 0}, {NAN, 0}, {4, 0}};
  std::vector<double> r = {0.1, -0.1, 0.2, 0.05};
  const SideBlocks s = SideBlockSums(px, r, {1, 1, 1, 0}, a, b, &scratch);
  EXPECT_EQ(s.n, 0);
  EXPECT_FALSE(SideLineVariance(s, Eigen::Vector2d(1, 0)).ok);
  r[1] = NAN;
  EXPECT_EQ(SideBlockSums(px, r, {1, 1, 1, 1}, a, b, &scratch).n, 0);
}

// A small marker whose every side lies in one block: the blocks cannot be told from the lines
// (c1 and c2 are 0 but for rounding), and no share is taken; the rounding once gave c = 1e26
// px^2 and poses that did not converge (10 px markers of Detector.ASubPixelTipPicksThePose-
// OfATenPixelMarker).
TEST(BlockVariances, SidesEachWithinOneBlockGiveNoShare) {
  const std::array<Eigen::Vector2d, 4> corners = {
      Eigen::Vector2d(0.8, 0.9), {6.2, 1.1}, {6.1, 6.3}, {0.7, 6.2}};
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0, 0.05);
  std::vector<CodecBlock> scratch;
  std::array<SideBlocks, 4> sums;
  double q1 = 0, a1 = 0;
  for (int k = 0; k < 4; ++k) {
    const std::vector<Eigen::Vector2d> px = PointsAlong(corners[k], corners[(k + 1) % 4], 1.0);
    std::vector<double> r(px.size());
    for (double& v : r) v = normal(rng);
    sums[k] = SideBlockSums(px, r, std::vector<char>(px.size(), 1), corners[k],
                            corners[(k + 1) % 4], &scratch);
    ASSERT_EQ(sums[k].N2, sums[k].n * sums[k].n);  // one block
    q1 += sums[k].q1, a1 += sums[k].a1;
  }
  const Eigen::Vector2d ac = BlockVariances(sums);
  EXPECT_EQ(ac.y(), 0);
  EXPECT_DOUBLE_EQ(ac.x(), q1 / a1);
}

// The four sides of a 40 px square turned by 20 degrees, a point every 1.5 px.
std::array<std::vector<Eigen::Vector2d>, 4> Square(std::array<Eigen::Vector2d, 4>* corners) {
  std::array<std::vector<Eigen::Vector2d>, 4> sides;
  for (int k = 0; k < 4; ++k) {
    const double t = 20 * M_PI / 180 + M_PI * (1.25 + 0.5 * k);
    (*corners)[k] = Eigen::Vector2d(60.3, 57.8) +
                    40 / std::sqrt(2.0) * Eigen::Vector2d(std::cos(t), std::sin(t));
  }
  for (int k = 0; k < 4; ++k) sides[k] = PointsAlong((*corners)[k], (*corners)[(k + 1) % 4], 1.5);
  return sides;
}

// Errors of covariance a I + c J drawn on the square's points, each side's line fitted: the
// mean of BlockVariances over the draws is (a, c) (the gate passes nearly every draw at an
// equal share; it biases c up a little where it drops the low draws); with c = 0 the gate passes
// a few per cent of them: one-sided 2 sigmas of a Gaussian would be 2.3 %, and the statistic,
// a quadratic form of few blocks, has a heavier tail (97 of 3000 draws here, 3.2 %, as the test
// prints).
TEST(BlockVariances, RecoversTheVariancesOfInjectedErrors) {
  std::array<Eigen::Vector2d, 4> corners;
  const auto sides = Square(&corners);
  std::array<Eigen::MatrixXd, 4> resid;
  for (int k = 0; k < 4; ++k) {
    Eigen::MatrixXd H, J;
    Explicit(sides[k], corners[k], corners[(k + 1) % 4], &H, &J);
    resid[k] = Eigen::MatrixXd::Identity(H.rows(), H.cols()) - H;
  }
  std::mt19937 rng(5);
  std::vector<CodecBlock> scratch;
  auto estimate = [&](double a, double c) {
    std::array<SideBlocks, 4> sums;
    for (int k = 0; k < 4; ++k) {
      const Eigen::VectorXd r = resid[k] * DrawErrors(sides[k], a, c, rng);
      sums[k] = SideBlockSums(sides[k], ToVector(r), std::vector<char>(r.size(), 1), corners[k],
                              corners[(k + 1) % 4], &scratch);
    }
    return BlockVariances(sums);
  };
  const int draws = 3000;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  int passed = 0;
  for (int i = 0; i < draws; ++i) {
    const Eigen::Vector2d ac = estimate(1.0, 1.0);
    mean += ac / draws;
    passed += ac.y() > 0;
  }
  EXPECT_GT(passed, 0.95 * draws);
  std::printf("a = 1, c = 1: mean estimate (%.3f, %.3f), c found in %d of %d draws\n", mean.x(),
              mean.y(), passed, draws);
  EXPECT_NEAR(mean.x(), 1.0, 0.05);
  EXPECT_NEAR(mean.y(), 1.0, 0.08);
  int false_alarms = 0;
  for (int i = 0; i < draws; ++i) false_alarms += estimate(1.0, 0.0).y() > 0;
  std::printf("a = 1, c = 0: c found in %d of %d draws\n", false_alarms, draws);
  EXPECT_GT(false_alarms, 0.005 * draws);
  EXPECT_LT(false_alarms, 0.06 * draws);
}

// The fitted line's place at the side's ends, over many draws, against SideLineVariance; and
// the scatter's mean square over n - 2 against its `scatter`.
TEST(SideLineVariance, IsTheFittedLinesScatterAtItsEnds) {
  std::array<Eigen::Vector2d, 4> corners;
  const auto sides = Square(&corners);
  const std::vector<Eigen::Vector2d>& px = sides[1];
  const Eigen::Vector2d a = corners[1], b = corners[2];
  const Eigen::Vector2d u = (b - a).normalized();
  const int n = static_cast<int>(px.size());
  Eigen::VectorXd s(n);
  for (int i = 0; i < n; ++i) s(i) = u.dot(px[i] - a);
  const double mean_s = s.mean();
  s.array() -= mean_s;
  const double S = s.squaredNorm(), end0 = -mean_s, end1 = (b - a).norm() - mean_s;
  std::vector<CodecBlock> scratch;
  const SideBlocks sums =
      SideBlockSums(px, std::vector<double>(n, 0), std::vector<char>(n, 1), a, b, &scratch);
  std::mt19937 rng(7);
  for (const Eigen::Vector2d& ac : {Eigen::Vector2d(1, 0), Eigen::Vector2d(0.5, 0.5)}) {
    const SideLineEnds ends = SideLineVariance(sums, ac);
    ASSERT_TRUE(ends.ok);
    const int draws = 20000;
    double v0 = 0, v1 = 0, c01 = 0, scatter = 0;
    for (int i = 0; i < draws; ++i) {
      const Eigen::VectorXd e = DrawErrors(px, ac.x(), ac.y(), rng);
      const double offset = e.mean(), slope = s.dot(e) / S;
      const double d0 = offset + slope * end0, d1 = offset + slope * end1;
      v0 += d0 * d0 / draws, v1 += d1 * d1 / draws, c01 += d0 * d1 / draws;
      scatter += (e.array() - offset - slope * s.array()).matrix().squaredNorm() / (n - 2) / draws;
    }
    EXPECT_NEAR(ends.v0, v0, 0.04 * v0);
    EXPECT_NEAR(ends.v1, v1, 0.04 * v1);
    EXPECT_NEAR(ends.covariance, c01, 0.04 * std::sqrt(v0 * v1));
    EXPECT_NEAR(ends.scatter, scatter, 0.02 * scatter);
    if (ac.y() == 0) {
      EXPECT_DOUBLE_EQ(ends.factor, 1.0);
    } else {
      // The ends err more than the scatter says: the share the blocks hold.
      EXPECT_GT(ends.factor, 1.5);
      EXPECT_NEAR(ends.factor,
                  0.5 *
                      (v0 / (1 / sums.n + end0 * end0 / S) + v1 / (1 / sums.n + end1 * end1 / S)) /
                      scatter,
                  0.05 * ends.factor);
    }
  }
}

}  // namespace
}  // namespace svms
