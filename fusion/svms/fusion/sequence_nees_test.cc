#include "svms/fusion/sequence_nees.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cstdio>
#include <random>

#include "svms/base/statistics.h"

namespace svms {
namespace {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

// A random positive-definite covariance of pose-like scales (1e-4 rad, 1e-3 m).
PoseCovariance RandomCovariance(std::mt19937_64* rng) {
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix<double, 6, 6> A;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) A(i, j) = g(*rng);
  Eigen::Matrix<double, 6, 1> scale;
  scale << 1e-4, 1e-4, 1e-4, 1e-3, 1e-3, 1e-3;
  return scale.asDiagonal() * (A * A.transpose() + Eigen::Matrix<double, 6, 6>::Identity()) *
         scale.asDiagonal();
}

// No common error: the band is chi-square(6 N) / N's, [5.70, 6.31] for 500 frames.
TEST(SequenceNees, WithoutACommonErrorTheBandIsChiSquareOfAllFrames) {
  std::mt19937_64 rng(1);
  std::vector<PoseCovariance> covariance;
  std::vector<Mat6X> bias(500, Mat6X(6, 0));
  for (int f = 0; f < 500; ++f) covariance.push_back(RandomCovariance(&rng));
  SequenceNeesBand band;
  std::string error;
  ASSERT_TRUE(ComputeSequenceNeesBand(covariance, bias, {}, &band, &error)) << error;
  EXPECT_EQ(band.frames, 500);
  EXPECT_EQ(band.common_columns, 0);
  EXPECT_NEAR(band.independent_lo, 5.70, 0.01);
  EXPECT_NEAR(band.independent_hi, 6.31, 0.01);
  // Monte-Carlo quantiles of 4000 trials: about 0.01 of standard error.
  EXPECT_NEAR(band.lo, band.independent_lo, 0.04);
  EXPECT_NEAR(band.hi, band.independent_hi, 0.04);
  EXPECT_NEAR(band.mean, 6.0, 0.01);
  EXPECT_EQ(band.common_share, 0);
}

// All of every frame's covariance is the common error (B_f B_f^T = Sigma_f): every frame's
// NEES is the one |z|^2, so the mean is one chi-square(6) draw, [1.24, 14.45], however many
// frames there are.
TEST(SequenceNees, AllCommonIsOneChiSquareSixDraw) {
  std::mt19937_64 rng(2);
  std::vector<PoseCovariance> covariance;
  std::vector<Mat6X> bias;
  for (int f = 0; f < 200; ++f) {
    covariance.push_back(RandomCovariance(&rng));
    bias.push_back(covariance.back().llt().matrixL());
  }
  SequenceNeesBand band;
  std::string error;
  ASSERT_TRUE(ComputeSequenceNeesBand(covariance, bias, {}, &band, &error)) << error;
  EXPECT_NEAR(band.common_share, 1.0, 1e-9);
  // chi-square(6)'s 2.5 % and 97.5 % quantiles (tables); the Monte-Carlo's standard errors
  // there are about 0.05 and 0.3.
  EXPECT_NEAR(band.lo, 1.2373, 0.15);
  EXPECT_NEAR(band.hi, 14.449, 0.9);
  EXPECT_NEAR(band.mean, 6.0, 0.15);
}

// Half of an identity covariance common, over many frames: the mean tends to 3 + |z|^2 / 2, so
// the band to 3 + [1.237, 14.449] / 2 = [3.62, 10.22]; the frames' own noise adds a little
// spread (its mean over 1000 frames has a standard deviation of about 0.04).
TEST(SequenceNees, HalfCommonIsThreePlusHalfAChiSquareSixDraw) {
  const PoseCovariance identity = PoseCovariance::Identity();
  std::vector<PoseCovariance> covariance(1000, identity);
  std::vector<Mat6X> bias(1000, Mat6X(std::sqrt(0.5) * identity));
  SequenceNeesBand band;
  std::string error;
  ASSERT_TRUE(ComputeSequenceNeesBand(covariance, bias, {}, &band, &error)) << error;
  EXPECT_NEAR(band.common_share, 0.5, 1e-12);
  EXPECT_NEAR(band.lo, 3.62, 0.1);
  EXPECT_NEAR(band.hi, 10.22, 0.4);
  EXPECT_NEAR(band.mean, 6.0, 0.15);
}

// A sequence of frames with their own noise N_f and a common error B_f z, drawn with the noise
// scaled by `noise_scale` and z by `draw_scale` (1: as the covariances say).
struct Sequence {
  std::vector<PoseCovariance> covariance;
  std::vector<Mat6X> bias;
  std::vector<Eigen::Matrix<double, 6, 1>> errors;
  Eigen::VectorXd z;
};
Sequence DrawSequence(std::mt19937_64* rng, int frames, int k, double noise_scale,
                      double draw_scale, int unseen_columns = 0) {
  std::normal_distribution<double> g(0, 1);
  Sequence s;
  s.z.resize(k);
  for (int j = 0; j < k; ++j) s.z[j] = draw_scale * g(*rng);
  for (int f = 0; f < frames; ++f) {
    const PoseCovariance noise = RandomCovariance(rng);
    Mat6X B(6, k);
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < k; ++j) B(i, j) = (j < k - unseen_columns ? 1e-3 * g(*rng) : 0.0);
    s.covariance.push_back(noise + B * B.transpose());
    s.bias.push_back(B);
    const Eigen::Matrix<double, 6, 6> root = noise.llt().matrixL();
    Eigen::Matrix<double, 6, 1> w;
    for (int i = 0; i < 6; ++i) w[i] = g(*rng);
    s.errors.push_back(noise_scale * root * w + B * s.z);
  }
  return s;
}

// With honest covariances the draw's chi-square is chi-square(rank) and the frames' own NEES
// 6 - rank / N on average; the estimate finds z; columns no frame responds to are not counted.
TEST(CommonDraw, HonestCovariancesGiveChiSquareOfTheSeenComponents) {
  std::mt19937_64 rng(4);
  double chi2 = 0, own = 0, z_error = 0, z_norm = 0;
  const int trials = 200, frames = 20, k = 8;
  for (int t = 0; t < trials; ++t) {
    const Sequence s = DrawSequence(&rng, frames, k, 1, 1, 1);
    CommonDrawEstimate e;
    std::string error;
    ASSERT_TRUE(EstimateCommonDraw(s.errors, s.covariance, s.bias, &e, &error)) << error;
    ASSERT_EQ(e.rank, k - 1);
    chi2 += e.chi2;
    own += e.own_nees_mean;
    z_error += (e.z - s.z).head(k - 1).squaredNorm();
    z_norm += s.z.head(k - 1).squaredNorm();
    EXPECT_EQ(e.z[k - 1], 0);  // the unseen component is not guessed
  }
  std::printf("honest: chi2 %.3f (rank 7), own NEES %.3f, |z_hat - z|^2 / |z|^2 %.4f\n",
              chi2 / trials, own / trials, z_error / z_norm);
  // chi-square(7) over 200 sequences: 7 +- 0.26; own NEES 6 - 7 / 20 = 5.65 +- 0.05 (a mean of
  // 6, as if z were known, is 7 standard errors off).
  EXPECT_NEAR(chi2 / trials, 7.0, 0.8);
  EXPECT_NEAR(own / trials, 5.65, 0.15);
  EXPECT_LT(z_error, 0.2 * z_norm);  // the sequence sees z well
}

// Which part is off: a draw twice as large as its covariance says doubles the chi-square and
// leaves the frames' own NEES; noise twice as large in variance doubles the own NEES and
// leaves the chi-square near rank.
TEST(CommonDraw, TellsTheCommonErrorsScaleFromTheFramesOwn) {
  std::mt19937_64 rng(5);
  const int trials = 200, frames = 20, k = 6;
  double chi2_draw = 0, own_draw = 0, chi2_noise = 0, own_noise = 0;
  for (int t = 0; t < trials; ++t) {
    CommonDrawEstimate e;
    std::string error;
    const Sequence a = DrawSequence(&rng, frames, k, 1, std::sqrt(2.0));
    ASSERT_TRUE(EstimateCommonDraw(a.errors, a.covariance, a.bias, &e, &error)) << error;
    chi2_draw += e.chi2, own_draw += e.own_nees_mean;
    const Sequence b = DrawSequence(&rng, frames, k, std::sqrt(2.0), 1);
    ASSERT_TRUE(EstimateCommonDraw(b.errors, b.covariance, b.bias, &e, &error)) << error;
    chi2_noise += e.chi2, own_noise += e.own_nees_mean;
  }
  std::printf("draw x2: chi2 %.3f, own NEES %.3f; noise x2: chi2 %.3f, own NEES %.3f\n",
              chi2_draw / trials, own_draw / trials, chi2_noise / trials, own_noise / trials);
  // Own NEES 6 - 6 / 20 = 5.7 (+- 0.05), twice that with the noise doubled (+- 0.1).
  EXPECT_NEAR(chi2_draw / trials, 12.0, 1.5);
  EXPECT_NEAR(own_draw / trials, 5.7, 0.15);
  EXPECT_LT(chi2_noise / trials, 8.0);
  EXPECT_NEAR(own_noise / trials, 2 * 5.7, 0.3);
}

TEST(SequenceNees, InputsThatDoNotFitAreErrorsNamingTheFrame) {
  const PoseCovariance identity = PoseCovariance::Identity();
  SequenceNeesBand band;
  std::string error;
  EXPECT_FALSE(ComputeSequenceNeesBand({}, {}, {}, &band, &error));
  EXPECT_NE(error.find("at least one frame"), std::string::npos) << error;
  EXPECT_FALSE(
      ComputeSequenceNeesBand({identity, identity}, {Mat6X(6, 2), Mat6X(6, 3)}, {}, &band, &error));
  EXPECT_NE(error.find("frame 1"), std::string::npos) << error;
  EXPECT_FALSE(ComputeSequenceNeesBand({identity, -identity}, {Mat6X(6, 0), Mat6X(6, 0)}, {}, &band,
                                       &error));
  EXPECT_NE(error.find("frame 1: its covariance is not positive definite"), std::string::npos)
      << error;
  EXPECT_FALSE(ComputeSequenceNeesBand({identity}, {Mat6X(2 * identity)}, {}, &band, &error));
  EXPECT_NE(error.find("frame 0: its bias factor's share exceeds its covariance"),
            std::string::npos)
      << error;
  CommonDrawEstimate e;
  // No common error: nothing to estimate, every frame's NEES its own.
  const Eigen::Matrix<double, 6, 1> one = Eigen::Matrix<double, 6, 1>::Constant(1);
  ASSERT_TRUE(EstimateCommonDraw({one, 2 * one}, {identity, identity}, {Mat6X(6, 0), Mat6X(6, 0)},
                                 &e, &error))
      << error;
  EXPECT_EQ(e.rank, 0);
  EXPECT_EQ(e.z.size(), 0);
  EXPECT_EQ(e.chi2, 0);
  EXPECT_DOUBLE_EQ(e.own_nees_mean, (6 + 24) / 2.0);
  // Columns no frame responds to: none seen.
  ASSERT_TRUE(EstimateCommonDraw({one}, {identity}, {Mat6X::Zero(6, 3)}, &e, &error)) << error;
  EXPECT_EQ(e.rank, 0);
  EXPECT_DOUBLE_EQ(e.own_nees_mean, 6);
  EXPECT_FALSE(EstimateCommonDraw({}, {identity}, {Mat6X(6, 0)}, &e, &error));
  EXPECT_NE(error.find("one error per covariance"), std::string::npos) << error;
  // All of the covariance common: no own share to weigh the frames by.
  EXPECT_FALSE(EstimateCommonDraw({Eigen::Matrix<double, 6, 1>::Zero()}, {identity},
                                  {Mat6X(identity)}, &e, &error));
  EXPECT_NE(error.find("frame 0: its own share of the covariance"), std::string::npos) << error;
}

}  // namespace
}  // namespace svms
