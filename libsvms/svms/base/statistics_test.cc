#include "svms/base/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace svms {
namespace {

TEST(Statistics, PercentileInterpolatesBetweenOrderStatistics) {
  EXPECT_DOUBLE_EQ(Percentile({0, 10}, 0.25), 2.5);
  EXPECT_DOUBLE_EQ(Percentile({5, 1, 4, 2, 3}, 0), 1);
  EXPECT_DOUBLE_EQ(Percentile({5, 1, 4, 2, 3}, 1), 5);
  EXPECT_DOUBLE_EQ(Percentile({5, 1, 4, 2, 3}, 0.5), 3);
  EXPECT_DOUBLE_EQ(Percentile({5, 1, 4, 2, 3}, 0.9), 4.6);  // rank 3.6
  EXPECT_DOUBLE_EQ(Percentile({1, 2, 3, 4}, 0.95), 3.85);   // rank 2.85
  EXPECT_DOUBLE_EQ(Percentile({7}, 0.3), 7);
  // p is clamped to [0, 1].
  EXPECT_DOUBLE_EQ(Percentile({1, 2, 3}, -0.5), 1);
  EXPECT_DOUBLE_EQ(Percentile({1, 2, 3}, 1.5), 3);
}

TEST(Statistics, NonFiniteValuesAreLeftOut) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_DOUBLE_EQ(Median({3, 1, 2, NAN}), 2);
  EXPECT_DOUBLE_EQ(Percentile({inf, 1, -inf, 3, NAN}, 1), 3);
  EXPECT_TRUE(std::isnan(Median({})));
  EXPECT_TRUE(std::isnan(Percentile({NAN, inf}, 0.5)));
}

TEST(Statistics, RmsIsTheRootOfTheMeanSquare) {
  EXPECT_DOUBLE_EQ(Rms({3, -4}), std::sqrt(12.5));
  EXPECT_DOUBLE_EQ(Rms({-2}), 2);
  EXPECT_TRUE(std::isnan(Rms({})));
}

TEST(Statistics, MedianOfAnEvenCountIsTheMeanOfTheMiddleTwo) {
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(Median({10, -10}), 0);
  EXPECT_DOUBLE_EQ(Median({2, 9, 4}), 4);
}

TEST(Statistics, BlurredRamp) {
  // At 0: sigma phi(0); far out, the ramp itself; its slope is Phi(x / sigma).
  EXPECT_NEAR(BlurredRamp(0, 0.7), 0.7 / std::sqrt(2 * M_PI), 1e-15);
  EXPECT_NEAR(BlurredRamp(5, 0.5), 5, 1e-12);
  EXPECT_NEAR(BlurredRamp(-5, 0.5), 0, 1e-12);
  const double h = 1e-5;
  EXPECT_NEAR((BlurredRamp(0.3 + h, 0.4) - BlurredRamp(0.3 - h, 0.4)) / (2 * h),
              0.5 * std::erfc(-0.3 / 0.4 / std::sqrt(2.0)), 1e-9);
}

TEST(Statistics, NormalQuantile) {
  EXPECT_NEAR(NormalQuantile(0.5), 0, 1e-15);
  EXPECT_NEAR(NormalQuantile(0.975), 1.959963984540054, 1e-14);
  EXPECT_NEAR(NormalQuantile(0.025), -1.959963984540054, 1e-14);
  EXPECT_NEAR(NormalQuantile(0.999), 3.090232306167813, 7e-14);
  EXPECT_NEAR(NormalQuantile(0.95), 1.644853626951472, 1e-14);
}

// Exact quantiles (tables; scipy.stats.chi2.ppf) against the Wilson-Hilferty approximation's
// stated error.
TEST(Statistics, ChiSquareQuantileIsWithinWilsonHilfertysError) {
  struct Case {
    double p, dof, exact, max_relative_error;
  };
  for (const Case& c : {Case{0.95, 3, 7.8147, 0.006}, Case{0.95, 6, 12.5916, 0.002},
                        Case{0.999, 6, 22.4577, 0.011}, Case{0.999, 10, 29.5883, 0.007},
                        Case{0.025, 600, 534.0186, 1e-5}, Case{0.975, 600, 669.7692, 1e-5}}) {
    const double q = ChiSquareQuantile(c.p, c.dof);
    EXPECT_NEAR(q, c.exact, c.max_relative_error * c.exact) << c.p << " " << c.dof;
  }
  // The approximation's own values (regression): 95 % for 3 and 6 dof.
  EXPECT_NEAR(ChiSquareQuantile(0.95, 3), 7.77500, 5e-5);
  EXPECT_NEAR(ChiSquareQuantile(0.95, 6), 12.56862, 5e-5);
  // The tabled constant is the exact value the approximation misses by 0.2 %.
  EXPECT_NEAR(ChiSquareQuantile(0.95, 6), kChi2Dof6P95, 0.002 * kChi2Dof6P95);
  // Monotone in p and in dof.
  EXPECT_LT(ChiSquareQuantile(0.9, 6), ChiSquareQuantile(0.95, 6));
  EXPECT_LT(ChiSquareQuantile(0.95, 6), ChiSquareQuantile(0.95, 8));
}

}  // namespace
}  // namespace svms
