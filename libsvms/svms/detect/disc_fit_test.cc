#include "svms/detect/disc_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "svms/base/random_draws.h"

namespace svms {
namespace {

// Area by counting the points of a fine grid inside both: independent of the closed form.
double AreaByCounting(double r, double x0, double x1, double y0, double y1) {
  const int n = 1500;
  int inside = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = x0 + (i + 0.5) * (x1 - x0) / n, y = y0 + (j + 0.5) * (y1 - y0) / n;
      inside += x * x + y * y <= r * r;
    }
  return inside * (x1 - x0) * (y1 - y0) / (double(n) * n);
}

TEST(DiscRectangleArea, KnownAreas) {
  const double r = 0.7;
  EXPECT_NEAR(DiscRectangleArea(r, -1, 1, -1, 1), M_PI * r * r, 1e-12);
  EXPECT_NEAR(DiscRectangleArea(r, 0, 1, 0, 1), M_PI * r * r / 4, 1e-12);
  EXPECT_NEAR(DiscRectangleArea(r, -1, 0, -1, 1), M_PI * r * r / 2, 1e-12);
  EXPECT_NEAR(DiscRectangleArea(r, 0.7, 2, -1, 1), 0, 1e-12);
  EXPECT_EQ(DiscRectangleArea(0, -1, 1, -1, 1), 0);
  EXPECT_EQ(DiscRectangleArea(r, 1, -1, -1, 1), 0);
  // A square inscribed in the circle.
  const double s = r / std::sqrt(2);
  EXPECT_NEAR(DiscRectangleArea(r, -s, s, -s, s), 4 * s * s, 1e-12);
}

TEST(DiscRectangleArea, MatchesCountingOnRandomPixels) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.2, 1.2), rr(0.2, 1.5);
  for (int k = 0; k < 40; ++k) {
    const double r = rr(rng), x0 = u(rng), y0 = u(rng);
    EXPECT_NEAR(DiscRectangleArea(r, x0, x0 + 1, y0, y0 + 1),
                AreaByCounting(r, x0, x0 + 1, y0, y0 + 1), 2e-3)
        << "r " << r << " x0 " << x0 << " y0 " << y0;
  }
}

TEST(DiscRectangleArea, PixelsOfAGridSumToTheDisc) {
  const double r = 0.43, cx = 0.31, cy = -0.27;
  double sum = 0;
  for (int y = -2; y <= 2; ++y)
    for (int x = -2; x <= 2; ++x)
      sum += DiscRectangleArea(r, x - 0.5 - cx, x + 0.5 - cx, y - 0.5 - cy, y + 0.5 - cy);
  EXPECT_NEAR(sum, M_PI * r * r, 1e-12);
}

// A `size` x `size` window with pixel (ox, oy) top-left, of a disc at `c` on a background,
// plus noise.
std::vector<double> Window(int size, double r, const Eigen::Vector2d& c, int ox, int oy,
                           double amplitude, double background, double noise, std::mt19937* rng) {
  std::normal_distribution<double> g(0, noise);
  std::vector<double> v(size * size);
  for (int i = 0; i < size * size; ++i) {
    const double x = ox + i % size - c.x(), y = oy + i / size - c.y();
    v[i] = background + amplitude * DiscRectangleArea(r, x - 0.5, x + 0.5, y - 0.5, y + 0.5) +
           (noise > 0 ? g(*rng) : 0);
  }
  return v;
}

TEST(FitDisc, FindsTheCentreOfASubPixelDiscOrSaysWhereItMayBe) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> off(-0.5, 0.5), rr(0.3, 1.0);
  for (int k = 0; k < 60; ++k) {
    const double r = rr(rng);
    const Eigen::Vector2d c = Eigen::Vector2d(102, 37) + DrawVector2(off, rng);
    const std::vector<double> v = Window(5, r, c, 100, 35, 140, 11, 0, &rng);
    const auto fit = FitDisc(v.data(), 5, 100, 35, r);
    ASSERT_TRUE(fit) << "r " << r << " c " << c.transpose();
    EXPECT_NEAR(fit->amplitude, 140, 3);
    EXPECT_NEAR(fit->background, 11, 0.2);
    EXPECT_LT((fit->centre - c).norm(), std::max(0.015, 3 * fit->sigma_px));
    for (int axis = 0; axis < 2; ++axis) {
      const double inside = 0.5 - r - std::abs(c(axis) - std::round(c(axis)));
      SCOPED_TRACE("r " + std::to_string(r) + " axis " + std::to_string(axis));
      if (inside > 0.05) {
        // Inside one pixel column (row) any place across it gives the same values: the middle,
        // with the spread of a uniform distribution over 1 - 2r.
        EXPECT_NEAR(fit->centre(axis), std::round(c(axis)), 0.01);
        EXPECT_GT(fit->sigma_px, 0.8 * (1 - 2 * r) / std::sqrt(12.0));
      } else if (inside < -0.05) {
        EXPECT_NEAR(fit->centre(axis), c(axis), 0.01);
      }
    }
    if (0.5 - r - (c - c.array().round().matrix()).cwiseAbs().minCoeff() < -0.05) {
      EXPECT_LT(fit->sigma_px, 0.02);
    }
  }
}

// With noise the centre scatters as the fit's own sigma says, and the centroid of the same
// values is pulled toward the pixel centre (what the fit is for). Noise of 0.5 grey levels
// is the simulator's at the black square (8 bits, shot and read noise); at 2 the disc's
// sliver in a neighbouring pixel is often lost, and the sigma must grow to say so.
TEST(FitDisc, SigmaMatchesTheScatterAndTheCentroidLocksToThePixel) {
  for (double noise : {0.5, 2.0}) {
    SCOPED_TRACE("noise " + std::to_string(noise));
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> off(-0.5, 0.5);
    const double r = 0.4;
    double err2 = 0, sigma2 = 0, centroid_err2 = 0;
    int n = 0;
    for (int k = 0; k < 400; ++k) {
      const Eigen::Vector2d c = Eigen::Vector2d(12, 20) + DrawVector2(off, rng);
      const std::vector<double> v = Window(5, r, c, 10, 18, 140, 10, noise, &rng);
      const auto fit = FitDisc(v.data(), 5, 10, 18, r);
      ASSERT_TRUE(fit);
      err2 += (fit->centre - c).squaredNorm() / 2;
      sigma2 += fit->sigma_px * fit->sigma_px;
      Eigen::Vector2d m = Eigen::Vector2d::Zero();
      double w = 0;
      for (int i = 0; i < 25; ++i) {
        const double wi = std::max(0.0, v[i] - 10);
        m += wi * Eigen::Vector2d(10 + i % 5, 18 + i / 5);
        w += wi;
      }
      centroid_err2 += (m / w - c).squaredNorm() / 2;
      ++n;
    }
    const double rms = std::sqrt(err2 / n), predicted = std::sqrt(sigma2 / n);
    EXPECT_GT(rms, 0.6 * predicted);
    EXPECT_LT(rms, 1.4 * predicted);
    if (noise < 1) {
      // Where the disc lies inside one pixel column the place is uniform over 1 - 2r:
      // 0.058 px RMS, a floor no estimate can beat; the centroid is near twice that.
      EXPECT_LT(rms, 0.065);
      EXPECT_GT(std::sqrt(centroid_err2 / n), 1.6 * rms);
    }
  }
}

// A disc of a few pixels, searched for within a pixel of the window's middle: the same place
// and sigma as a search of the whole window, at hundredths of a pixel from the truth.
TEST(FitDisc, ASearchNearTheMiddleFindsWhatTheWholeWindowsDoes) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> off(-0.5, 0.5);
  for (double r : {1.2, 2.5, 4.0}) {
    const int h = static_cast<int>(std::ceil(r + 1.5)), size = 2 * h + 1;
    for (int k = 0; k < 10; ++k) {
      const Eigen::Vector2d c = Eigen::Vector2d(30, 40) + DrawVector2(off, rng);
      const std::vector<double> v = Window(size, r, c, 30 - h, 40 - h, 150, 12, 0.5, &rng);
      const auto whole = FitDisc(v.data(), size, 30 - h, 40 - h, r);
      const auto near = FitDisc(v.data(), size, 30 - h, 40 - h, r, 1.0);
      ASSERT_TRUE(whole && near) << "r " << r;
      EXPECT_LT((near->centre - whole->centre).norm(), 1e-9) << "r " << r;
      EXPECT_NEAR(near->sigma_px, whole->sigma_px, 1e-9) << "r " << r;
      EXPECT_LT((near->centre - c).norm(), 0.03) << "r " << r;
    }
  }
}

// A search shorter than three coarse steps (under 0.1 px) is walked on the fine grid alone: a
// disc within it is found, not refused as if the best place were at the search's edge.
TEST(FitDisc, AVeryShortSearchStillFindsTheDisc) {
  std::mt19937 rng(23);
  for (double search : {0.02, 0.05, 0.09}) {
    const double r = 2.0;
    const int h = 4, size = 2 * h + 1;
    const Eigen::Vector2d c(30 + 0.4 * search, 40 - 0.3 * search);
    const std::vector<double> v = Window(size, r, c, 30 - h, 40 - h, 150, 12, 0.2, &rng);
    const auto fit = FitDisc(v.data(), size, 30 - h, 40 - h, r, search);
    ASSERT_TRUE(fit) << "search " << search;
    EXPECT_LT((fit->centre - c).norm(), 0.02) << "search " << search;
  }
}

// Tops of a few pixels under more noise than the simulator's: the sigma still describes the
// scatter (or overstates it a little, never understates).
TEST(FitDisc, SigmaOfLargerDiscsMatchesTheScatter) {
  for (double r : {1.2, 3.0, 5.0})
    for (double noise : {2.0, 8.0}) {
      SCOPED_TRACE("r " + std::to_string(r) + " noise " + std::to_string(noise));
      std::mt19937 rng(31);
      std::uniform_real_distribution<double> off(-0.5, 0.5);
      const int h = static_cast<int>(std::ceil(r + 1.5)), size = 2 * h + 1;
      double err2 = 0, sigma2 = 0;
      const int n = 200;
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector2d c = Eigen::Vector2d(50, 60) + DrawVector2(off, rng);
        const auto fit = FitDisc(Window(size, r, c, 50 - h, 60 - h, 150, 12, noise, &rng).data(),
                                 size, 50 - h, 60 - h, r, 1.0);
        ASSERT_TRUE(fit);
        err2 += (fit->centre - c).squaredNorm() / 2;
        sigma2 += fit->sigma_px * fit->sigma_px;
      }
      const double ratio = std::sqrt(err2 / sigma2);
      EXPECT_GT(ratio, 0.5);
      EXPECT_LT(ratio, 1.2);
    }
}

// A disc outside the restricted search, or a search too narrow to hold a place: no answer,
// rather than the edge of the search with a small sigma.
TEST(FitDisc, ARestrictedSearchThatMissesTheDiscSaysSo) {
  std::mt19937 rng(2);
  const double r = 2;
  const std::vector<double> v = Window(7, r, Eigen::Vector2d(4.4, 3.0), 0, 0, 150, 12, 0.5, &rng);
  EXPECT_TRUE(FitDisc(v.data(), 7, 0, 0, r));        // the whole window finds it
  EXPECT_FALSE(FitDisc(v.data(), 7, 0, 0, r, 1.0));  // 1.4 px off the middle
  EXPECT_TRUE(FitDisc(v.data(), 7, 0, 0, r, 1.6));
  const std::vector<double> w = Window(7, r, Eigen::Vector2d(3.2, 3.1), 0, 0, 150, 12, 0.5, &rng);
  EXPECT_FALSE(FitDisc(w.data(), 7, 0, 0, r, 1e-9));
}

TEST(FitDisc, RefusesAFlatWindowAndBadArguments) {
  std::mt19937 rng(1);
  const std::vector<double> flat = Window(5, 0.4, Eigen::Vector2d(2, 2), 0, 0, 0, 20, 1.0, &rng);
  const auto fit = FitDisc(flat.data(), 5, 0, 0, 0.4);
  // Noise alone may fit a faint disc; never a confident one.
  if (fit) {
    EXPECT_GT(fit->sigma_px, 0.1);
  }
  const std::vector<double> v = Window(5, 0.4, Eigen::Vector2d(2, 2), 0, 0, 100, 20, 0, &rng);
  EXPECT_FALSE(FitDisc(v.data(), 2, 0, 0, 0.4));
  EXPECT_FALSE(FitDisc(v.data(), 5, 0, 0, 0));
  EXPECT_FALSE(FitDisc(v.data(), 5, 0, 0, 0.4, -1));
  EXPECT_FALSE(FitDisc(v.data(), 5, 0, 0, 0.4, std::nan("")));
  EXPECT_FALSE(FitDisc(v.data(), 5, 0, 0, std::nan("")));
  EXPECT_FALSE(FitDisc(v.data(), 5, 0, 0, -0.4));
}

}  // namespace
}  // namespace svms
