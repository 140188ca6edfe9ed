#include "svms/fusion/sequence_nees.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
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
}

}  // namespace
}  // namespace svms
