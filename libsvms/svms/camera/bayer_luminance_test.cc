#include "svms/camera/bayer_luminance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/camera/photometric.h"

namespace svms {
namespace {

constexpr BayerPattern kPatterns[] = {BayerPattern::kRggb, BayerPattern::kBggr, BayerPattern::kGrbg,
                                      BayerPattern::kGbrg};

// The colour (0 r, 1 g, 2 b) of pixel (x, y) under `p`, written out independently of the code.
int ColourAt(BayerPattern p, int x, int y) {
  const char* name = p == BayerPattern::kRggb   ? "RGGB"
                     : p == BayerPattern::kBggr ? "BGGR"
                     : p == BayerPattern::kGrbg ? "GRBG"
                                                : "GBRG";
  const char c = name[(y % 2) * 2 + x % 2];
  return c == 'R' ? 0 : c == 'G' ? 1 : 2;
}

// A grey scene `grey` (CV_64F, linear, 0..1) seen through a mosaic with channel sensitivities
// `qe` (r, g, b), scaled to 16 bits.
cv::Mat Mosaic(const cv::Mat& grey, BayerPattern p, const std::array<double, 3>& qe) {
  cv::Mat m(grey.size(), CV_16UC1);
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x)
      m.at<uint16_t>(y, x) = cv::saturate_cast<uint16_t>(
          std::lround(60000 * qe[ColourAt(p, x, y)] * grey.at<double>(y, x)));
  return m;
}

// A vertical black/white edge at x = `edge` (area-sampled: the pixel it crosses is the mix).
cv::Mat EdgeScene(int size, double edge, double dark, double bright) {
  cv::Mat g(size, size, CV_64F);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double cover = std::clamp(x + 1 - edge, 0.0, 1.0);  // bright share of the pixel
      g.at<double>(y, x) = dark + (bright - dark) * cover;
    }
  return g;
}

// Where a row of `img` steps from `lo` to `hi`, from the bright area of pixels 8..39: exact for
// an area-sampled step, and moved by exactly the centroid of any linear filter (0 for a
// symmetric one) or by whatever a non-linear one does to the area.
double EdgeFromArea(const cv::Mat& img, int row, double lo, double hi) {
  double area = 0;
  for (int x = 8; x < 40; ++x) area += (img.at<uint16_t>(row, x) - lo) / (hi - lo);
  return 40 - area;
}

TEST(BayerLuminanceKernel, KeepsLuminanceAndRemovesTheChrominanceCarriers) {
  const cv::Matx<float, 5, 5> k = BayerLuminanceKernel();
  auto response = [&](double wx, double wy) {
    std::complex<double> sum = 0;
    for (int y = -2; y <= 2; ++y)
      for (int x = -2; x <= 2; ++x)
        sum += double(k(y + 2, x + 2)) * std::exp(std::complex<double>(0, wx * x + wy * y));
    return std::abs(sum);
  };
  EXPECT_NEAR(response(0, 0), 1.0, 1e-6);
  EXPECT_NEAR(response(M_PI, M_PI), 0.0, 1e-6);
  EXPECT_NEAR(response(M_PI, 0), 0.0, 1e-6);
  EXPECT_NEAR(response(0, M_PI), 0.0, 1e-6);
  for (int y = 0; y < 5; ++y)  // symmetric: it cannot move an edge
    for (int x = 0; x < 5; ++x) {
      EXPECT_EQ(k(y, x), k(4 - y, x));
      EXPECT_EQ(k(y, x), k(y, 4 - x));
      EXPECT_EQ(k(y, x), k(x, y));
    }
}

TEST(EstimateBayerGains, RecoversTheChannelSensitivitiesOfAGreyScene) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> level(0.2, 0.9);
  cv::Mat grey(64, 64, CV_64F);
  for (int y = 0; y < 64; y += 4)  // flat 4 x 4 patches of random grey
    for (int x = 0; x < 64; x += 4) grey(cv::Rect(x, y, 4, 4)).setTo(level(rng));
  const std::array<double, 3> qe = {0.55, 1.0, 0.75};
  for (BayerPattern p : kPatterns) {
    const std::array<double, 3> g = EstimateBayerGains(Mosaic(grey, p, qe), p);
    EXPECT_NEAR(g[0], 1 / 0.55, 2e-3 / 0.55) << BayerPatternName(p);
    EXPECT_EQ(g[1], 1.0);
    EXPECT_NEAR(g[2], 1 / 0.75, 2e-3 / 0.75) << BayerPatternName(p);
  }
  // Nothing to balance by in a black frame: no gains at all.
  const cv::Mat black(64, 64, CV_16UC1, cv::Scalar(0));
  EXPECT_EQ(EstimateBayerGains(black, BayerPattern::kRggb), (std::array<double, 3>{1, 1, 1}));
}

TEST(BayerLuminance, FlatGreyIsFlatAndColourIsItsDoubleGreenMean) {
  cv::Mat out;
  for (BayerPattern p : kPatterns) {
    const cv::Mat grey(32, 32, CV_64F, cv::Scalar(0.5));
    BayerLuminance(Mosaic(grey, p, {0.55, 1.0, 0.75}), p, {1 / 0.55, 1, 1 / 0.75}, &out);
    double lo, hi;
    cv::minMaxLoc(out, &lo, &hi);  // every pixel, borders included
    EXPECT_NEAR(lo, 30000, 2) << BayerPatternName(p);
    EXPECT_NEAR(hi, 30000, 2) << BayerPatternName(p);
    // A saturated red patch read with unit gains: (R + 2 G + B) / 4 of it.
    cv::Mat red(32, 32, CV_16UC1);
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x) red.at<uint16_t>(y, x) = ColourAt(p, x, y) == 0 ? 40000 : 0;
    BayerLuminance(red, p, {1, 1, 1}, &out);
    cv::minMaxLoc(out, &lo, &hi);
    EXPECT_NEAR(lo, 10000, 1) << BayerPatternName(p);
    EXPECT_NEAR(hi, 10000, 1) << BayerPatternName(p);
  }
}

TEST(BayerLuminance, LeavesASharpGreyEdgeWhereItIsAndOpenCvMovesIt) {
  // A sharp vertical edge at sub-pixel offsets, through a mosaic with unequal sensitivities:
  // the luminance has its step where the grey scene has it, to a thousandth of a pixel (the
  // 16-bit rounding) at every phase and every pattern. OpenCV's edge-aware demosaic of the
  // same mosaic moves it by hundredths at some phases.
  const std::array<double, 3> qe = {0.55, 1.0, 0.75};
  double worst = 0, worst_opencv = 0;
  for (BayerPattern p : kPatterns) {
    for (double edge = 20.0; edge < 22.0; edge += 0.125) {
      const cv::Mat grey = EdgeScene(48, edge, 0.1, 0.8);
      const cv::Mat mosaic = Mosaic(grey, p, qe);
      cv::Mat lum;
      BayerLuminance(mosaic, p, EstimateBayerGains(mosaic, p), &lum);
      const double lo = 60000 * 0.1, hi = 60000 * 0.8;
      for (int row = 10; row < 12; ++row)  // both rows of a cell
        worst = std::max(worst, std::abs(EdgeFromArea(lum, row, lo, hi) - edge));
      PhotometricModel m;
      m.bayer = p;
      m.demosaic = BayerMethod::kOpenCv;
      cv::Mat cv_lum;
      ASSERT_TRUE(LinearizeImage(mosaic, m, &cv_lum).ok());
      const double l0 = cv_lum.at<uint16_t>(10, 2), l1 = cv_lum.at<uint16_t>(10, 45);
      for (int row = 10; row < 12; ++row)
        worst_opencv = std::max(worst_opencv, std::abs(EdgeFromArea(cv_lum, row, l0, l1) - edge));
    }
  }
  EXPECT_LT(worst, 0.001);
  EXPECT_GT(worst_opencv, 0.01);
  RecordProperty("worst_edge_shift_px", std::to_string(worst));
  RecordProperty("worst_edge_shift_opencv_px", std::to_string(worst_opencv));
}

TEST(LinearizeImage, BayerMosaicOfAGreySceneBecomesTheScene) {
  // Through LinearizeImage's default method: black level and white level first, then the
  // balanced luminance; a grey ramp comes back as the ramp (each pixel to 0.5 %).
  cv::Mat grey(40, 40, CV_64F);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) grey.at<double>(y, x) = 0.1 + 0.02 * x;
  const std::array<double, 3> qe = {0.55, 1.0, 0.75};
  cv::Mat raw(40, 40, CV_16UC1);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x)
      raw.at<uint16_t>(y, x) = std::lround(
          256 + (4095 - 256) * qe[ColourAt(BayerPattern::kGrbg, x, y)] * grey.at<double>(y, x));
  PhotometricModel m;
  m.bayer = BayerPattern::kGrbg;
  m.black_level = 256;
  m.white_level = 4095;
  cv::Mat out;
  ASSERT_TRUE(LinearizeImage(raw, m, &out).ok());
  for (int y = 2; y < 38; ++y)
    for (int x = 2; x < 38; ++x)
      ASSERT_NEAR(out.at<uint16_t>(y, x) / 65535.0, grey.at<double>(y, x), 0.005) << x << "," << y;
}

}  // namespace
}  // namespace svms
