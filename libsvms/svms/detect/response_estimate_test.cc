#include "svms/detect/response_estimate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/camera/photometric.h"

namespace svms {
namespace {

// A square of half side `h` px about (cx, cy), turned by `a` radians: its exact corners.
Detection Square(double cx, double cy, double h, double a) {
  Detection d;
  for (int c = 0; c < 4; ++c) {
    const double t = a + M_PI / 4 + c * M_PI / 2;
    d.corners[c] =
        Eigen::Vector2d(cx + h * std::sqrt(2) * std::cos(t), cy + h * std::sqrt(2) * std::sin(t));
  }
  return d;
}

// Black squares (reflectance 0.05) in white (0.9) surrounds at several angles, rendered in
// linear light (exact pixel coverage, then a Gaussian blur of `blur` px), encoded through
// `response` into 8 bits with noise of sigma 0.004 in linear units plus, with `shot` > 0,
// shot noise of sigma shot * sqrt(value) (a sensor of 1 / shot^2 electrons at full scale);
// their detections carry the exact corners.
void Squares(const Response& response, double blur, uint32_t seed, cv::Mat* img,
             std::vector<Detection>* dets, double shot = 0) {
  constexpr int kW = 960, kH = 640, kS = 16;
  cv::Mat lin(kH, kW, CV_32F, cv::Scalar(0.9));
  dets->clear();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, M_PI / 2);
  for (int k = 0; k < 24; ++k) {
    const double cx = 80 + 160 * (k % 6) + 0.37 * k, cy = 80 + 160 * (k / 6), h = 30;
    const double a = angle(rng), ca = std::cos(a), sa = std::sin(a);
    dets->push_back(Square(cx, cy, h, a));
    // Each pixel's covered fraction, from 16 x 16 point samples over its area (pixel centres
    // at integers): exact to 1/256, with nothing of an anti-aliasing filter's own shape.
    for (int y = static_cast<int>(cy - 1.5 * h); y <= cy + 1.5 * h; ++y)
      for (int x = static_cast<int>(cx - 1.5 * h); x <= cx + 1.5 * h; ++x) {
        int in = 0;
        for (int j = 0; j < kS; ++j)
          for (int i = 0; i < kS; ++i) {
            const double u = x - 0.5 + (i + 0.5) / kS - cx, v = y - 0.5 + (j + 0.5) / kS - cy;
            in += std::abs(ca * u + sa * v) < h && std::abs(-sa * u + ca * v) < h;
          }
        lin.at<float>(y, x) = static_cast<float>(0.9 - 0.85 * in / (kS * kS));
      }
  }
  cv::GaussianBlur(lin, lin, cv::Size(0, 0), blur);
  std::normal_distribution<double> noise(0, 0.004);
  img->create(kH, kW, CV_8UC1);
  std::normal_distribution<double> unit(0, 1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double l = lin.at<float>(y, x);
      const double read = noise(rng);  // two statements: one fixed order of the draws
      const double photon = shot * std::sqrt(std::max(l, 0.0)) * unit(rng);
      img->at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
          255 * response.FromLinear(std::clamp(l + read + photon, 0.0, 1.0)));
    }
}

// Squares as a lens and its pixels make them: the light blurred by a Gaussian of `blur` px
// before each pixel integrates it over its area (the blurred square is exactly the product of
// two blurred intervals in the square's own axes; 8 x 8 point samples per pixel integrate that
// smooth light), encoded through `response` into 16 bits without noise.
void ExactSquares(const Response& response, double blur, uint32_t seed, cv::Mat* img,
                  std::vector<Detection>* dets) {
  constexpr int kW = 960, kH = 640, kS = 8;
  img->create(kH, kW, CV_16UC1);
  img->setTo(cv::Scalar(65535 * response.FromLinear(0.9)));
  dets->clear();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, M_PI / 2);
  auto interval = [blur](double u, double h) {
    return 0.5 * (std::erf((u + h) / (blur * std::sqrt(2.0))) -
                  std::erf((u - h) / (blur * std::sqrt(2.0))));
  };
  for (int k = 0; k < 24; ++k) {
    const double cx = 80 + 160 * (k % 6) + 0.37 * k, cy = 80 + 160 * (k / 6) + 0.21 * k, h = 30;
    const double a = angle(rng), ca = std::cos(a), sa = std::sin(a);
    dets->push_back(Square(cx, cy, h, a));
    for (int y = static_cast<int>(cy - 1.6 * h); y <= cy + 1.6 * h; ++y)
      for (int x = static_cast<int>(cx - 1.6 * h); x <= cx + 1.6 * h; ++x) {
        double dark = 0;
        for (int j = 0; j < kS; ++j)
          for (int i = 0; i < kS; ++i) {
            const double u = x - 0.5 + (i + 0.5) / kS - cx, v = y - 0.5 + (j + 0.5) / kS - cy;
            dark += interval(ca * u + sa * v, h) * interval(-sa * u + ca * v, h);
          }
        img->at<uint16_t>(y, x) =
            cv::saturate_cast<uint16_t>(65535 * response.FromLinear(0.9 - 0.85 * dark / (kS * kS)));
      }
  }
}

// Where the pixels integrate light that the lens has blurred (as in a camera), every patch reads
// the truth whatever its edge's angle and sub-pixel phase, so 480 patches give the response to
// within 0.01, and their spread says so.
TEST(EstimateGammaFromEdges, EdgesAtAnyPixelPhaseReadTheSameResponse) {
  for (const auto& [response, truth] :
       {std::pair{Response::Linear(), 1.0}, std::pair{Response::Gamma(2.2), 2.2}}) {
    cv::Mat img;
    std::vector<Detection> dets;
    ExactSquares(response, 0.7, 3, &img, &dets);
    std::vector<EdgePatch> patches;
    CollectEdgePatches(img, dets, 0, 0, &patches);
    const ResponseEstimate e = EstimateGammaFromEdges(patches);
    ASSERT_EQ(e.patches, 480) << response.Name();
    EXPECT_NEAR(e.gamma, truth, 0.01) << response.Name() << " sigma " << e.sigma;
    EXPECT_LT(e.sigma, 0.01) << response.Name();
  }
}

// The detector finds edges a little off where it reads them through another curve (toward the
// dark side, through a curve too flat): each patch's centre is found again, to 1e-4 px, so
// squares found 0.1 px too large or too small read as those found exactly, sharp (0.4 px) or
// blurred (1.2 px).
TEST(EstimateGammaFromEdges, EdgesFoundOffCentreReadTheSameResponse) {
  for (const double blur : {0.4, 1.2})
    for (const double offset : {-0.1, 0.1}) {
      cv::Mat img;
      std::vector<Detection> dets;
      ExactSquares(Response::Gamma(2.2), blur, 5, &img, &dets);
      for (Detection& d : dets) {
        Eigen::Vector2d centre = Eigen::Vector2d::Zero();
        for (const auto& c : d.corners) centre += 0.25 * c;
        for (auto& c : d.corners)
          c = centre + (c - centre) * (1 + offset * std::sqrt(2) / (c - centre).norm());
      }
      std::vector<EdgePatch> patches;
      CollectEdgePatches(img, dets, 0, 0, &patches);
      const ResponseEstimate e = EstimateGammaFromEdges(patches);
      ASSERT_GT(e.patches, 400) << blur << " " << offset;
      EXPECT_NEAR(e.gamma, 2.2, 0.02)
          << "blur " << blur << " offset " << offset << " sigma " << e.sigma;
    }
}

TEST(EstimateGammaFromEdges, RecoversTheResponseOfTheImages) {
  for (const auto& [response, truth] :
       {std::pair{Response::Linear(), 1.0}, std::pair{Response::Gamma(2.2), 2.2},
        std::pair{Response::Gamma(1.8), 1.8}}) {
    cv::Mat img;
    std::vector<Detection> dets;
    Squares(response, 0.8, 7, &img, &dets);
    std::vector<EdgePatch> patches;
    CollectEdgePatches(img, dets, 0, 0, &patches);
    EXPECT_EQ(patches.size(), 24u * 4 * 5);
    const ResponseEstimate e = EstimateGammaFromEdges(patches);
    ASSERT_GE(e.patches, 400) << response.Name();
    EXPECT_NEAR(e.gamma, truth, 0.1) << response.Name() << " sigma " << e.sigma;
    EXPECT_GT(e.sigma, 0);
    EXPECT_LT(e.sigma, 0.12);
    EXPECT_LE(e.asymmetry, e.asymmetry_linear);
  }
}

// Shot noise makes the bright side of every edge noisier than its dark side, and a
// profile's skewness, a ratio of its noisy moments, then leans one way. The estimate stays
// within 4 % of the truth and within 4 of its own sigmas; one line per profile with the mean of
// the profiles' skewness does not (it reads these squares as 2.01 and 0.92).
TEST(EstimateGammaFromEdges, ShotNoiseDoesNotBiasTheEstimate) {
  for (const auto& [response, truth] :
       {std::pair{Response::Linear(), 1.0}, std::pair{Response::Gamma(2.2), 2.2}}) {
    std::vector<EdgePatch> patches;
    for (uint32_t seed = 1; seed <= 8; ++seed) {
      cv::Mat img;
      std::vector<Detection> dets;
      Squares(response, 0.8, seed, &img, &dets, 0.025);
      CollectEdgePatches(img, dets, 0, 0, &patches);
    }
    const ResponseEstimate e = EstimateGammaFromEdges(patches);
    ASSERT_GE(e.patches, 3200) << response.Name();
    EXPECT_NEAR(e.gamma, truth, 0.04 * truth) << response.Name() << " sigma " << e.sigma;
    EXPECT_LE(std::abs(e.gamma - truth), 4 * e.sigma) << response.Name();
  }
}

TEST(EstimateGammaFromEdges, SrgbReadsAsItsEdgesPureGammaAndLinearIsContradicted) {
  cv::Mat img;
  std::vector<Detection> dets;
  Squares(Response::Srgb(), 1.0, 9, &img, &dets);
  std::vector<EdgePatch> patches;
  CollectEdgePatches(img, dets, 0, 0, &patches);
  const ResponseEstimate e = EstimateGammaFromEdges(patches);
  // Read as a pure gamma across edges between 0.05 and 0.9 of white behind 1 px of blur, sRGB
  // is 2.57 (the gamma that makes the continuous edge unskewed, a 1-D computation; 2.46 at
  // 0.6 px): its linear toe and offset bend it more than 2.2 does.
  EXPECT_NEAR(e.gamma, 2.57, 0.15);
  EXPECT_GT(e.asymmetry_linear, 4 * e.asymmetry_srgb);
  EXPECT_LT(e.asymmetry, e.asymmetry_linear);
}

TEST(EstimateGammaFromEdges, BinaryEdgesSayNothing) {
  // Pure black and white pixels (artwork at its own resolution): any gamma reads them alike.
  std::vector<EdgePatch> patches(100);
  for (EdgePatch& p : patches) {
    p.room = 20;
    for (int y = -5; y <= 5; ++y)
      for (int x = -4; x <= 4; ++x) {
        p.code.push_back(x < 0 ? 0 : 1);
        p.across.push_back(static_cast<float>(x) + 0.5f);
        p.along_weight.push_back(static_cast<float>(std::exp(-y * y / 8.0)));
        p.half.push_back(y >= 0);
      }
  }
  EXPECT_EQ(EstimateGammaFromEdges(patches).patches, 0);
}

TEST(EstimateGammaFromEdges, TooFewEdgesGiveNoEstimate) {
  std::vector<EdgePatch> few(5);
  EXPECT_EQ(EstimateGammaFromEdges(few).patches, 0);
  // Patches whose per-pixel fields are out of step are left out, not read past their end.
  cv::Mat img;
  std::vector<Detection> dets;
  Squares(Response::Gamma(2.2), 0.8, 7, &img, &dets);
  std::vector<EdgePatch> broken;
  CollectEdgePatches(img, dets, 0, 0, &broken);
  for (EdgePatch& p : broken) p.half.pop_back();
  EXPECT_EQ(EstimateGammaFromEdges(broken).patches, 0);
  EXPECT_EQ(EstimateGammaFromEdges({}).gamma, 1);
}

// Every count kept of every count collected: patch k * n / keep in slot k (as svms calibrate
// keeps an image's share), each patch whole; all of them when there are no more than `keep`.
TEST(KeepEvenly, KeepsEvenlySpacedPatchesInTheirOrder) {
  for (size_t n = 0; n <= 40; ++n) {
    for (size_t keep = 1; keep <= 45; ++keep) {
      std::vector<EdgePatch> patches(n);
      for (size_t i = 0; i < n; ++i) {
        patches[i].side = static_cast<uint32_t>(i);
        patches[i].code.assign(i + 1, static_cast<uint16_t>(i));
      }
      KeepEvenly(keep, &patches);
      ASSERT_EQ(patches.size(), std::min(n, keep)) << n << " " << keep;
      for (size_t k = 0; k < patches.size(); ++k) {
        const size_t from = keep >= n ? k : k * n / keep;
        ASSERT_EQ(patches[k].side, from) << n << " " << keep << " " << k;
        ASSERT_EQ(patches[k].code, std::vector<uint16_t>(from + 1, static_cast<uint16_t>(from)))
            << n << " " << keep << " " << k;
      }
    }
  }
}

}  // namespace
}  // namespace svms
