#include "svms/bench/edge_information.h"

#include <gtest/gtest.h>

#include <cmath>

namespace svms {
namespace {

TEST(EdgeOffsetInformation, AnUnblurredEdgeAlongTheColumnsGivesOnePerRow) {
  // Each row's one pixel straddling the edge changes by exactly d.
  EXPECT_NEAR(EdgeOffsetInformation(0, 0), 1.0, 1e-4);
  // The trapezoid at 45 degrees: (a - b / 3) / a^2 with a = b = sqrt(1/2).
  EXPECT_NEAR(EdgeOffsetInformation(0, M_PI / 4), (2.0 / 3) / std::sqrt(0.5), 1e-4);
}

TEST(EdgeOffsetInformation, ATinyBlurGivesTheUnblurredValue) {
  for (double theta : {0.1, 0.5, 0.75})
    EXPECT_NEAR(EdgeOffsetInformation(0.005, theta), EdgeOffsetInformation(0, theta), 0.01)
        << theta;
}

TEST(EdgeOffsetInformation, AWideBlurGivesTheGaussianLimit) {
  // k tends to a Gaussian of variance s^2 + 1/12 (the trapezoid's variance is (a^2 + b^2) /
  // 12): the integral of its square is 1 / (2 sqrt(pi) sigma).
  for (double theta : {0.2, 0.6}) {
    const double sigma = std::sqrt(9 + 1.0 / 12);
    EXPECT_NEAR(EdgeOffsetInformation(3, theta) * 2 * std::sqrt(M_PI) * sigma, 1.0, 2e-3);
  }
}

// An independent count: the pixels of a 100 px stretch of edge, each pixel's derivative taken
// over 32 x 32 points of its area.
TEST(EdgeOffsetInformation, MatchesASumOverPixels) {
  const double s = 0.7, theta = 20 * M_PI / 180, length = 100, d = 0.3;
  const double nx = std::cos(theta), ny = std::sin(theta);
  constexpr int kSub = 32;
  double sum = 0;
  for (int y = -80; y <= 80; ++y)
    for (int x = -80; x <= 80; ++x) {
      const double along = -ny * x + nx * y, across = nx * x + ny * y - d;
      if (std::abs(along) > length / 2 || std::abs(across) > 6) continue;
      double g = 0;
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i) {
          const double u =
              nx * (x + (i + 0.5) / kSub - 0.5) + ny * (y + (j + 0.5) / kSub - 0.5) - d;
          g += std::exp(-0.5 * u * u / (s * s)) / (std::sqrt(2 * M_PI) * s);
        }
      g /= kSub * kSub;
      sum += g * g;
    }
  EXPECT_NEAR(sum / length / EdgeOffsetInformation(s, theta), 1.0, 0.01);
}

TEST(EdgeBlurBoundFactor, GrowsWithTheBlurAndIsOneAgainstItself) {
  EXPECT_NEAR(EdgeBlurBoundFactor(0.7, 0.7), 1.0, 1e-12);
  EXPECT_NEAR(EdgeBlurBoundFactor(0, 0), 1.0, 1e-12);
  double last = 1;
  for (double s : {0.2, 0.4, 0.7, 1.0, 2.0}) {
    const double f = EdgeBlurBoundFactor(s);
    EXPECT_GT(f, last) << s;
    last = f;
  }
  // Against a reference blur: the ratio of the two factors against none.
  EXPECT_NEAR(EdgeBlurBoundFactor(1.0, 0.4), EdgeBlurBoundFactor(1.0) / EdgeBlurBoundFactor(0.4),
              0.02);
}

}  // namespace
}  // namespace svms
