#include "svms/camera/photometric.h"

#include <gtest/gtest.h>

#include <cmath>

namespace svms {
namespace {

TEST(Response, KnownAnswersAndRoundTrips) {
  const Response srgb = Response::Srgb();
  // IEC 61966-2-1: 0.5 encoded is 0.21404 linear; the linear toe below 0.04045.
  EXPECT_NEAR(srgb.ToLinear(0.5), 0.2140411, 1e-6);
  EXPECT_NEAR(srgb.ToLinear(0.02), 0.02 / 12.92, 1e-12);
  EXPECT_NEAR(Response::Gamma(2.2).ToLinear(0.5), std::pow(0.5, 2.2), 1e-12);
  EXPECT_EQ(Response::Linear().ToLinear(0.3), 0.3);
  Response table;
  ASSERT_TRUE(Response::Table({0, 0.1, 0.4, 1}, &table).ok());
  EXPECT_NEAR(table.ToLinear(0.5), 0.25, 1e-12);  // between 1/3 (0.1) and 2/3 (0.4)
  for (const Response& r : {srgb, Response::Gamma(1.8), Response::Linear(), table})
    for (double l = 0; l <= 1; l += 0.05)
      EXPECT_NEAR(r.ToLinear(r.FromLinear(l)), l, 1e-9) << r.Name() << " at " << l;
}

TEST(Response, ParseNamesAndErrors) {
  Response r;
  ASSERT_TRUE(Response::Parse("gamma:2.2", &r).ok());
  EXPECT_EQ(r.Name(), "gamma:2.2");
  ASSERT_TRUE(Response::Parse("srgb", &r).ok());
  EXPECT_EQ(r.Name(), "srgb");
  EXPECT_EQ(Response::Parse("log", &r).message(),
            "--response \"log\": unknown response; expected linear, srgb, gamma:G (e.g. "
            "gamma:2.2) or table:FILE");
  EXPECT_FALSE(Response::Parse("gamma:0", &r).ok());
  EXPECT_FALSE(Response::Parse("gamma:2.2x", &r).ok());
  EXPECT_FALSE(Response::Table({0, 0.5, 0.4, 1}, &r).ok());  // decreasing
  EXPECT_FALSE(Response::Table({0.1, 1}, &r).ok());          // not from 0
  BayerPattern b;
  EXPECT_TRUE(ParseBayerPattern("rggb", &b).ok());
  EXPECT_EQ(b, BayerPattern::kRggb);
  EXPECT_EQ(ParseBayerPattern("RGBG", &b).message(),
            "--bayer \"RGBG\": unknown Bayer pattern; expected RGGB, BGGR, GRBG or GBRG");
}

TEST(PhotometricFile, RoundTripsAndNamesBadFields) {
  PhotometricModel m;
  m.response = Response::Gamma(2.4);
  m.black_level = 256;
  m.white_level = 4095;
  m.bayer = BayerPattern::kGbrg;
  PhotometricModel back;
  ASSERT_TRUE(ParsePhotometricJson(PhotometricToJson(m), "p.json", &back).ok());
  EXPECT_EQ(back.response.Name(), "gamma:2.4");
  EXPECT_EQ(back.black_level, 256);
  EXPECT_EQ(back.white_level, 4095);
  EXPECT_EQ(back.bayer, BayerPattern::kGbrg);
  EXPECT_NE(ParsePhotometricJson(R"({"type": "svms.photometric", "response": "srgb",
      "black_level": 300, "white_level": 200})",
                                 "p.json", &back)
                .message()
                .find("p.json: black_level 300"),
            std::string::npos);
  EXPECT_NE(ParsePhotometricJson(R"({"type": "svms.photometric", "response": "warm",
      "black_level": 0, "white_level": 0})",
                                 "p.json", &back)
                .message()
                .find("p.json: response:"),
            std::string::npos);
}

TEST(LinearizeImage, LevelsCurveAndIdentity) {
  // 8-bit linear grey: the image itself, no copy.
  cv::Mat g(4, 4, CV_8UC1, cv::Scalar(77));
  cv::Mat out;
  ASSERT_TRUE(LinearizeImage(g, PhotometricModel(), &out).ok());
  EXPECT_EQ(out.data, g.data);
  // sRGB 8-bit: 128 -> 0.2158605 of 65535.
  PhotometricModel srgb;
  srgb.response = Response::Srgb();
  g.setTo(128);
  ASSERT_TRUE(LinearizeImage(g, srgb, &out).ok());
  ASSERT_EQ(out.type(), CV_16UC1);
  EXPECT_EQ(out.at<uint16_t>(1, 1), std::lround(65535 * Response::Srgb().ToLinear(128 / 255.0)));
  // A 12-bit raw in 16 bits with a black level: 256 -> 0, 4095 -> 65535, mid-way -> half.
  PhotometricModel raw;
  raw.black_level = 256;
  raw.white_level = 4095;
  cv::Mat r16 = (cv::Mat_<uint16_t>(1, 4) << 100, 256, 2175, 4095);
  ASSERT_TRUE(LinearizeImage(r16, raw, &out).ok());
  EXPECT_EQ(out.at<uint16_t>(0, 0), 0);
  EXPECT_EQ(out.at<uint16_t>(0, 1), 0);
  EXPECT_NEAR(out.at<uint16_t>(0, 2), 65535 * (2175.0 - 256) / (4095 - 256), 1);
  EXPECT_EQ(out.at<uint16_t>(0, 3), 65535);
  raw.white_level = 70000;
  EXPECT_FALSE(LinearizeImage(r16, raw, &out).ok());
}

TEST(LinearizeImage, ColourBecomesLuminanceInLinearLight) {
  // sRGB pure red (255, 0, 0) is 0.2126 of white's luminance in linear light; its encoded
  // grey by OpenCV's weights (0.299 x 255) would read as 0.0703 linear.
  cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(0, 0, 255));
  PhotometricModel srgb;
  srgb.response = Response::Srgb();
  cv::Mat out;
  ASSERT_TRUE(LinearizeImage(bgr, srgb, &out).ok());
  EXPECT_NEAR(out.at<uint16_t>(0, 0) / 65535.0, 0.2126, 1e-3);
}

TEST(LinearizeImage, BayerPatternsAreDemosaicedWhereTheirColoursAre) {
  // A mosaic whose red pixels are bright and the rest dark, through OpenCV's demosaic: read
  // with the right pattern the luminance is red's weight of it everywhere away from the
  // border; with another pattern the bright pixels are taken for another colour.
  const std::pair<BayerPattern, cv::Point> red_at[] = {{BayerPattern::kRggb, {0, 0}},
                                                       {BayerPattern::kBggr, {1, 1}},
                                                       {BayerPattern::kGrbg, {1, 0}},
                                                       {BayerPattern::kGbrg, {0, 1}}};
  for (const auto& [pattern, red] : red_at) {
    cv::Mat mosaic(16, 16, CV_16UC1, cv::Scalar(0));
    for (int y = red.y; y < 16; y += 2)
      for (int x = red.x; x < 16; x += 2) mosaic.at<uint16_t>(y, x) = 40000;
    PhotometricModel m;
    m.bayer = pattern;
    m.demosaic = BayerMethod::kOpenCv;
    cv::Mat out;
    ASSERT_TRUE(LinearizeImage(mosaic, m, &out).ok());
    EXPECT_NEAR(out.at<uint16_t>(8, 8), 0.2126 * 40000, 0.02 * 40000) << BayerPatternName(pattern);
    PhotometricModel wrong = m;
    wrong.bayer = pattern == BayerPattern::kRggb ? BayerPattern::kBggr : BayerPattern::kRggb;
    ASSERT_TRUE(LinearizeImage(mosaic, wrong, &out).ok());
    EXPECT_GT(std::abs(out.at<uint16_t>(8, 8) - 0.2126 * 40000), 0.05 * 40000);
  }
  cv::Mat bgr(4, 4, CV_8UC3);
  PhotometricModel m;
  m.bayer = BayerPattern::kRggb;
  cv::Mat out;
  EXPECT_FALSE(LinearizeImage(bgr, m, &out).ok());
}

}  // namespace
}  // namespace svms
