#include "svms/detect/noise_model.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "svms/camera/photometric.h"

namespace svms {
namespace {

// A 16-bit linear image of flat patches at `levels` (electron-like units: 1 unit = 1 DN) with
// read noise `read` and shot noise of gain `gain` (variance gain L), clipped to [0, 65535].
cv::Mat Patches(const std::vector<double>& levels, double read, double gain, uint32_t seed,
                int size = 512) {
  cv::Mat img(size, size, CV_16UC1);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  const int band = size / static_cast<int>(levels.size());
  for (int y = 0; y < size; ++y) {
    const double L = levels[std::min<size_t>(y / band, levels.size() - 1)];
    for (int x = 0; x < size; ++x) {
      const double v = L + std::sqrt(read * read + gain * L) * n01(rng);
      img.at<uint16_t>(y, x) = static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 65535L));
    }
  }
  return img;
}

// `lin16` sRGB-encoded to 8 bits, as a camera writes it.
cv::Mat SrgbEncode8(const cv::Mat& lin16) {
  const Response srgb = Response::Srgb();
  cv::Mat srgb8(lin16.size(), CV_8UC1);
  for (int y = 0; y < lin16.rows; ++y)
    for (int x = 0; x < lin16.cols; ++x)
      srgb8.at<uint8_t>(y, x) = static_cast<uint8_t>(
          std::lround(255 * srgb.FromLinear(lin16.at<uint16_t>(y, x) / 65535.0)));
  return srgb8;
}

// A raw12 frame as a sensor stores it (12 bits above a black level of 256 in 16-bit words) of
// Patches' levels (the first band black, with its read noise on both sides of the black level,
// as a raw frame keeps it), in linear 16-bit units `read` and `gain`.
cv::Mat Raw12Frame(double read, double gain, uint32_t seed) {
  const cv::Mat lin16 =
      Patches({0, 300, 800, 2000, 5000, 9000, 16000, 40000}, read, gain, seed, 1024);
  cv::Mat raw(lin16.size(), CV_16UC1);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  for (int y = 0; y < lin16.rows; ++y)
    for (int x = 0; x < lin16.cols; ++x) {
      const double lin = y < 128 ? read * n01(rng) : lin16.at<uint16_t>(y, x);
      raw.at<uint16_t>(y, x) = static_cast<uint16_t>(
          std::clamp(std::lround(256 + lin / 65535.0 * (4095 - 256)), 0L, 4095L));
    }
  return raw;
}

TEST(EstimateNoise, RecoversReadNoiseAndGainOnFlatPatches) {
  const cv::Mat img = Patches({500, 2000, 8000, 20000, 40000}, 30, 2.0, 1);
  const NoiseModel m = EstimateNoise(img);
  ASSERT_TRUE(m.valid());
  EXPECT_NEAR(m.read_sigma, 30, 0.25 * 30);
  EXPECT_NEAR(m.shot_gain, 2.0, 0.15 * 2.0);
}

TEST(EstimateNoise, APassedDeadlineStopsTheEstimateAndTheRescaling) {
  const cv::Mat img = Patches({500, 2000, 8000, 20000, 40000}, 30, 2.0, 1);
  const auto now = std::chrono::steady_clock::now();
  NoiseModel m;
  EXPECT_FALSE(EstimateNoise(img, now - std::chrono::seconds(1), &m));
  EXPECT_FALSE(m.valid());
  ASSERT_TRUE(EstimateNoise(img, now + std::chrono::hours(1), &m));
  const NoiseModel whole = EstimateNoise(img);
  EXPECT_EQ(m.read_sigma, whole.read_sigma);
  EXPECT_EQ(m.shot_gain, whole.shot_gain);
  cv::Mat out8;
  EXPECT_GT(StabiliseVariance(img, m, &out8), 0);
  EXPECT_EQ(StabiliseVariance(img, m, &out8, now - std::chrono::seconds(1)), 0);
}

// A black background clipped at 0 (space): its spread is less than the noise; the estimate
// must come from the unclipped parts and stay within 25 % of the truth.
TEST(EstimateNoise, ABlackClippedBackgroundDoesNotBiasIt) {
  const cv::Mat img = Patches({0, 0, 0, 3000, 30000}, 40, 1.5, 2);
  const NoiseModel m = EstimateNoise(img);
  ASSERT_TRUE(m.valid());
  EXPECT_NEAR(m.read_sigma, 40, 0.25 * 40) << "gain " << m.shot_gain;
  EXPECT_NEAR(m.Sigma(3000), std::sqrt(40 * 40 + 1.5 * 3000),
              0.1 * std::sqrt(40 * 40 + 1.5 * 3000));
}

// Saturated glints: clipped at the top, left out.
TEST(EstimateNoise, SaturatedGlintsAreLeftOut) {
  const cv::Mat img = Patches({65535, 65535, 1000, 5000, 20000}, 25, 1.0, 3);
  const NoiseModel m = EstimateNoise(img);
  EXPECT_NEAR(m.read_sigma, 25, 0.25 * 25);
  EXPECT_NEAR(m.shot_gain, 1.0, 0.2);
}

// A gamma-encoded 8-bit image (sRGB, as a JPEG would be before compression), turned back into
// linear light: the estimate is of the noise in linear light, within 25 % at mid grey.
TEST(EstimateNoise, WorksInLinearLightAfterAToneCurve) {
  // Noise in linear light, 16-bit units: read 150, gain 8 (a noisy small-pixel camera).
  const cv::Mat lin16 = Patches({0, 1500, 6000, 15000, 30000}, 150, 8, 4);
  const cv::Mat srgb8 = SrgbEncode8(lin16);
  PhotometricModel pm;
  pm.response = Response::Srgb();
  cv::Mat back;
  ASSERT_TRUE(LinearizeImage(srgb8, pm, &back).ok());
  const NoiseModel m = EstimateNoise(back);
  ASSERT_TRUE(m.valid());
  const double truth = std::sqrt(150 * 150 + 8 * 15000.0);
  EXPECT_NEAR(m.Sigma(15000), truth, 0.25 * truth);
  // Read on the encoded values themselves, the same patch would look several times noisier in
  // the darks than in the brights: the linear estimate's darks are not inflated.
  EXPECT_LT(m.read_sigma, 3 * 150);
}

// What `svms render`'s srgb8 profile writes, in linear 16-bit units: read noise 4 e- and a
// full well of 15,000 e- (17.5 units, gain 4.37 units per unit), sRGB-encoded to 8 bits and
// turned back into linear light. The codes' rounding (20 units apart in the darks, 400 in the
// brights) is more than the read noise at every level: it must be taken out code by code.
TEST(EstimateNoise, TheCodesRoundingIsTakenOutOfAnSrgbImage) {
  const double unit = 65535.0 / 15000, read = 4 * unit, gain = unit;
  PhotometricModel pm;
  pm.response = Response::Srgb();
  for (uint32_t seed : {6u, 7u, 8u}) {
    const cv::Mat lin16 =
        Patches({300, 800, 2000, 5000, 9000, 16000, 26000, 40000}, read, gain, seed, 1024);
    const cv::Mat srgb8 = SrgbEncode8(lin16);
    cv::Mat back;
    ASSERT_TRUE(LinearizeImage(srgb8, pm, &back).ok());
    const NoiseModel m = EstimateNoise(back);
    ASSERT_TRUE(m.valid());
    EXPECT_NEAR(m.read_sigma, read, 0.25 * read) << "seed " << seed;
    EXPECT_NEAR(m.shot_gain, gain, 0.1 * gain) << "seed " << seed;
  }
}

// The jpeg_srgb profile's frames: the same sensor, sRGB-encoded and compressed by libjpeg at
// quality 85, which smooths the flat areas' noise away (under a code's step). No noise is
// reported rather than what the few edge-laden bins left would say.
TEST(EstimateNoise, AJpegWhoseCodecRemovedTheNoiseReportsNone) {
  const double unit = 65535.0 / 15000;
  PhotometricModel pm;
  pm.response = Response::Srgb();
  const cv::Mat lin16 =
      Patches({300, 800, 2000, 5000, 9000, 16000, 26000, 40000}, 4 * unit, unit, 12, 1024);
  const cv::Mat srgb8 = SrgbEncode8(lin16);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", srgb8, bytes, {cv::IMWRITE_JPEG_QUALITY, 85}));
  const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  cv::Mat back;
  ASSERT_TRUE(LinearizeImage(decoded, pm, &back).ok());
  const NoiseModel m = EstimateNoise(back);
  EXPECT_TRUE(m.valid());
  EXPECT_EQ(m.read_sigma, 0);
  EXPECT_EQ(m.shot_gain, 0);
}

// Some brightness levels of an sRGB frame noiseless under their codes (flat areas a codec
// smoothed), the others noisy (the same sensor as above): where the hidden levels hold most
// samples no noise is reported; where the noisy ones do, their noise is, within the same 25 %
// and 10 % as above.
TEST(EstimateNoise, TheHiddenBinsDecideOnlyWhereTheyHoldMostSamples) {
  const double unit = 65535.0 / 15000, read = 4 * unit, gain = unit;
  PhotometricModel pm;
  pm.response = Response::Srgb();
  const std::vector<double> levels = {300, 800, 2000, 5000, 9000, 16000, 26000, 40000};
  const cv::Mat quiet = Patches(levels, 0.5, 1e-4, 15, 1024);
  const cv::Mat noisy = Patches(levels, read, gain, 16, 1024);
  const int band = 1024 / 8;
  for (const std::vector<int>& noisy_bands :
       {std::vector<int>{1, 3, 5}, std::vector<int>{0, 1, 3, 5, 6}}) {
    cv::Mat lin16 = quiet.clone();
    for (int b : noisy_bands)
      noisy.rowRange(b * band, (b + 1) * band).copyTo(lin16.rowRange(b * band, (b + 1) * band));
    cv::Mat back;
    ASSERT_TRUE(LinearizeImage(SrgbEncode8(lin16), pm, &back).ok());
    const NoiseModel m = EstimateNoise(back);
    ASSERT_TRUE(m.valid()) << noisy_bands.size();
    if (noisy_bands.size() < 4) {
      EXPECT_EQ(m.read_sigma, 0);
      EXPECT_EQ(m.shot_gain, 0);
    } else {
      EXPECT_NEAR(m.read_sigma, read, 0.25 * read);
      EXPECT_NEAR(m.shot_gain, gain, 0.1 * gain);
    }
  }
}

// The raw12 profile's frames: 12 bits above a black level of 256 in 16-bit words, read noise
// about one code (16.7 units per code in linear light). Turned into linear light, the black
// background is clipped at 0 and the read noise is seen only through the darkest unclipped
// patch, where it is a fifth of the variance: three seeds give 15.5, 17.6 and 22.1 for 17.5, so
// it is held to 35 % there. Measured as stored (EstimateStoredNoise), the black rows' values
// around the black level, below it included, give the read noise itself: 15 %. The gain to 10 %
// either way, both in the linear image's units.
TEST(EstimateNoise, ARaw12FrameGivesItsReadNoiseFromTheLinearImageAndBetterAsStored) {
  const double unit = 65535.0 / 15000, read = 4 * unit, gain = unit;
  PhotometricModel pm;
  pm.black_level = 256;
  pm.white_level = 4095;
  for (uint32_t seed : {9u, 10u, 11u}) {
    const cv::Mat raw = Raw12Frame(read, gain, seed);
    cv::Mat back;
    ASSERT_TRUE(LinearizeImage(raw, pm, &back).ok());
    const NoiseModel linear = EstimateNoise(back);
    ASSERT_TRUE(linear.valid());
    EXPECT_NEAR(linear.read_sigma, read, 0.35 * read) << "seed " << seed;
    EXPECT_NEAR(linear.shot_gain, gain, 0.1 * gain) << "seed " << seed;
    NoiseModel m;
    ASSERT_TRUE(EstimateStoredNoise(raw, pm, std::chrono::steady_clock::time_point::max(), &m));
    ASSERT_TRUE(m.valid());
    EXPECT_NEAR(m.read_sigma, read, 0.15 * read) << "seed " << seed;
    EXPECT_NEAR(m.shot_gain, gain, 0.1 * gain) << "seed " << seed;
  }
  // Where the stored values hold nothing the linear image does not: no estimate.
  const cv::Mat img = Patches({500, 2000}, 30, 2.0, 1);
  NoiseModel m;
  const auto forever = std::chrono::steady_clock::time_point::max();
  PhotometricModel srgb;
  srgb.response = Response::Srgb();
  srgb.black_level = 256;
  PhotometricModel no_black;
  PhotometricModel mosaic = pm;
  mosaic.bayer = BayerPattern::kRggb;
  for (const PhotometricModel& other : {srgb, no_black, mosaic})
    EXPECT_FALSE(EstimateStoredNoise(img, other, forever, &m));
  // A frame clipped at its black level (nothing below 256, but for two dead pixels): its dark
  // areas hide the noise.
  cv::Mat clipped;
  cv::max(Raw12Frame(read, gain, 9), 256, clipped);
  clipped.at<uint16_t>(0, 0) = clipped.at<uint16_t>(4, 4) = 0;
  EXPECT_FALSE(EstimateStoredNoise(clipped, pm, forever, &m));
  EXPECT_FALSE(EstimateStoredNoise(img, pm, std::chrono::steady_clock::now(), &m));
}

// An 8-bit linear capture whose levels were stretched by 1.5 (codes 0-170 to 0-255, every
// third output code never used: a combed histogram) and written in 16 bits. Its ranks skip the
// unused codes everywhere, so a rank is 1.5 codes on average, not the smaller gap: read noise
// 2 input codes (770 units) and gain 20 must come back within 25 % and 15 %.
TEST(EstimateNoise, ALevelsStretchedImageWithACombedHistogramGivesItsNoise) {
  const double read = 2 * 65535.0 / 170, gain = 20;
  for (uint32_t seed : {13u, 14u}) {
    const cv::Mat lin16 =
        Patches({3000, 8000, 15000, 25000, 35000, 45000, 55000}, read, gain, seed, 1024);
    cv::Mat combed(lin16.size(), CV_16UC1);
    for (int y = 0; y < lin16.rows; ++y)
      for (int x = 0; x < lin16.cols; ++x) {
        const long in8 = std::lround(lin16.at<uint16_t>(y, x) / 65535.0 * 170);
        combed.at<uint16_t>(y, x) = static_cast<uint16_t>(257 * std::lround(1.5 * in8));
      }
    const NoiseModel m = EstimateNoise(combed);
    ASSERT_TRUE(m.valid());
    EXPECT_NEAR(m.read_sigma, read, 0.25 * read) << "seed " << seed << ", gain " << m.shot_gain;
    EXPECT_NEAR(m.shot_gain, gain, 0.15 * gain) << "seed " << seed;
  }
}

TEST(EstimateNoise, EightBitImagesAndTheirScale) {
  cv::Mat img(400, 400, CV_8UC1);
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0, 1);
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 400; ++x) {
      const double L = y < 200 ? 60 : 180;
      img.at<uint8_t>(y, x) = static_cast<uint8_t>(
          std::clamp(std::lround(L + std::sqrt(4 + L / 20) * n01(rng)), 0L, 255L));
    }
  const NoiseModel m = EstimateNoise(img);
  EXPECT_NEAR(m.Sigma(60), std::sqrt(4 + 3.0), 0.2 * std::sqrt(7.0));
  EXPECT_NEAR(m.Sigma(180), std::sqrt(4 + 9.0), 0.2 * std::sqrt(13.0));
  const NoiseModel s = m.Scaled(257);
  EXPECT_NEAR(s.Sigma(257 * 180), 257 * m.Sigma(180), 1e-6 * 257 * m.Sigma(180));
  EXPECT_FALSE(EstimateNoise(cv::Mat(4, 4, CV_8UC1, cv::Scalar(7))).valid());
}

}  // namespace
}  // namespace svms
