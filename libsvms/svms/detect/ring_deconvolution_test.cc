#include "svms/detect/ring_deconvolution.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/marker/marker_model.h"

namespace svms {
namespace {

constexpr int kFine = 8;  // the test's own renderer samples each pixel 8 x 8 times

// Pixels (the centre of the top-left pixel at (0, 0)) from the unit marker plane (black square
// of side 1 centred on the origin, y up), through OpenCV's own four-point solver.
Eigen::Matrix3d PixelFromUnit(const std::array<Eigen::Vector2d, 4>& corners) {
  const std::array<cv::Point2f, 4> src = {cv::Point2f(-0.5f, 0.5f), cv::Point2f(0.5f, 0.5f),
                                          cv::Point2f(0.5f, -0.5f), cv::Point2f(-0.5f, -0.5f)};
  std::array<cv::Point2f, 4> dst;
  for (int k = 0; k < 4; ++k)
    dst[k] = cv::Point2f(static_cast<float>(corners[k].x()), static_cast<float>(corners[k].y()));
  const cv::Mat h = cv::getPerspectiveTransform(src.data(), dst.data());
  Eigen::Matrix3d H;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) H(r, c) = h.at<double>(r, c);
  return H;
}

// A marker's printed brightness at unit-plane point (x, y): the test's own geometry, each cell
// found as the one whose centre (MarkerModel::BitCellCentre) is within half a cell.
double Albedo(double x, double y, uint64_t word, double black, double white, double quiet,
              double beyond) {
  static const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
  const double m = std::max(std::abs(x), std::abs(y)), half_cell = 1.0 / 12;
  if (m <= 0.5) return black;
  if (m <= 5.0 / 6) return white;
  if (m <= 1.0) {
    for (int i = 0; i < Svms44::kBits; ++i) {
      const Eigen::Vector2d c = unit.BitCellCentre(i);
      if (std::abs(x - c.x()) <= half_cell && std::abs(y - c.y()) <= half_cell)
        return (word >> i) & 1 ? white : black;
    }
    return white;
  }
  return m <= 7.0 / 6 ? quiet : beyond;
}

// The marker with these corners drawn 8 times finer, blurred there by a Gaussian of `sigma`
// pixels (OpenCV), each pixel the mean of its 8 x 8 samples (its area), then Gaussian noise and
// 8 bits.
cv::Mat RenderMarker(const std::array<Eigen::Vector2d, 4>& corners, uint64_t word, double sigma,
                     double noise, std::mt19937* rng, int size = 64) {
  const Eigen::Matrix3d unit_from_pixel = PixelFromUnit(corners).inverse();
  cv::Mat fine(size * kFine, size * kFine, CV_32F);
  for (int j = 0; j < fine.rows; ++j)
    for (int i = 0; i < fine.cols; ++i) {
      // The fine sample's centre in pixels.
      const double x = (i + 0.5) / kFine - 0.5, y = (j + 0.5) / kFine - 0.5;
      const Eigen::Vector3d u = unit_from_pixel * Eigen::Vector3d(x, y, 1);
      fine.at<float>(j, i) =
          static_cast<float>(Albedo(u.x() / u.z(), u.y() / u.z(), word, 30, 200, 60, 110));
    }
  if (sigma > 0) cv::GaussianBlur(fine, fine, cv::Size(), sigma * kFine);
  cv::Mat coarse;
  cv::resize(fine, coarse, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  std::normal_distribution<float> g(0, static_cast<float>(noise));
  for (float& v : cv::Mat_<float>(coarse)) v += g(*rng);
  cv::Mat out;
  coarse.convertTo(out, CV_8U);
  return out;
}

// A square of side `side` px centred near (32, 32), turned by `turn` radians.
std::array<Eigen::Vector2d, 4> Square(double side, double turn, double cx = 32.3,
                                      double cy = 31.6) {
  std::array<Eigen::Vector2d, 4> q;
  const double s[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};  // y down
  for (int k = 0; k < 4; ++k) {
    const double x = side * s[k][0], y = side * s[k][1];
    q[k] = Eigen::Vector2d(cx + std::cos(turn) * x - std::sin(turn) * y,
                           cy + std::sin(turn) * x + std::cos(turn) * y);
  }
  return q;
}

int Flips(uint64_t a, uint64_t b) {
  return __builtin_popcountll((a ^ b) & ((uint64_t{1} << Svms44::kBits) - 1));
}

// 8.5 px markers behind 0.7 px of blur with 2 grey levels of noise, a dark quiet zone and a
// mid-grey background: the cells are 1.4 px, and a threshold at each cell's centre (SampleBits)
// misreads several. Read at their true corners, the deconvolved ring is the codeword; the blur
// it keeps is the candidate nearest the truth; the square and the stripe come out at their
// levels.
TEST(ReadRingDeconvolved, ReadsEightPixelRingsBehindABlur) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  std::uniform_real_distribution<double> turn(0, M_PI / 2);
  static const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
  int plain_flips = 0, deconvolved_flips = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const uint64_t word = Svms44::Codeword(id(rng));
    const std::array<Eigen::Vector2d, 4> q = Square(8.5, turn(rng));
    const cv::Mat image = RenderMarker(q, word, 0.7, 2.0, &rng);
    const Eigen::Matrix3d H = PixelFromUnit(q);
    const RingDeconvolution d = ReadRingDeconvolved(image, H);
    ASSERT_TRUE(d.ok) << trial;
    deconvolved_flips += Flips(d.word, word);
    plain_flips += Flips(SampleBits(image, H, unit).word, word);
    EXPECT_EQ(Flips(d.word, word), 0) << trial;
    EXPECT_DOUBLE_EQ(d.blur_sigma_px, 0.65) << trial;
    EXPECT_NEAR(d.black, 30, 6) << trial;
    EXPECT_NEAR(d.white, 200, 6) << trial;
    EXPECT_LT(d.residual_rms, 4) << trial;
    EXPECT_GT(d.pixels, 300) << trial;
  }
  RecordProperty("plain_flips", plain_flips);
  EXPECT_GE(plain_flips, 12);
  EXPECT_EQ(deconvolved_flips, 0);
}

// The blur is chosen by the marker's own pixels: a sharp image keeps the sharpest candidate, a
// blurrier one a wider one.
TEST(ReadRingDeconvolved, ChoosesTheBlurFromThePixels) {
  std::mt19937 rng(4);
  const uint64_t word = Svms44::Codeword(1234);
  const std::array<Eigen::Vector2d, 4> q = Square(9.0, 0.3);
  const RingDeconvolution sharp =
      ReadRingDeconvolved(RenderMarker(q, word, 0.0, 1.0, &rng), PixelFromUnit(q));
  const RingDeconvolution blurred =
      ReadRingDeconvolved(RenderMarker(q, word, 1.2, 1.0, &rng), PixelFromUnit(q));
  ASSERT_TRUE(sharp.ok);
  ASSERT_TRUE(blurred.ok);
  EXPECT_DOUBLE_EQ(sharp.blur_sigma_px, 0.25);
  EXPECT_DOUBLE_EQ(blurred.blur_sigma_px, 1.2);
  EXPECT_EQ(Flips(sharp.word, word), 0);
  EXPECT_LE(Flips(blurred.word, word), 2);
}

// Corners up to 0.2 px off along each axis (as step 8's are on such markers behind JPEG): the
// footprints still cover their cells, and the deconvolved reading stays within two flips where the
// cells' centres no longer do.
TEST(ReadRingDeconvolved, StaysNearTheCodewordWithCornersTenthsOfAPixelOff) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  std::uniform_real_distribution<double> turn(0, M_PI / 2), off(-0.2, 0.2);
  static const MarkerModel unit = MarkerModel::Standard(0, 1.0, 0);
  int within_two = 0, plain_within_two = 0;
  const int trials = 16;
  for (int trial = 0; trial < trials; ++trial) {
    const uint64_t word = Svms44::Codeword(id(rng));
    const std::array<Eigen::Vector2d, 4> q = Square(8.5, turn(rng));
    const cv::Mat image = RenderMarker(q, word, 0.7, 2.0, &rng);
    std::array<Eigen::Vector2d, 4> moved = q;
    for (Eigen::Vector2d& c : moved) c += Eigen::Vector2d(off(rng), off(rng));
    const Eigen::Matrix3d H = PixelFromUnit(moved);
    const RingDeconvolution d = ReadRingDeconvolved(image, H);
    ASSERT_TRUE(d.ok);
    within_two += Flips(d.word, word) <= 2;
    plain_within_two += Flips(SampleBits(image, H, unit).word, word) <= 2;
  }
  RecordProperty("within_two", within_two);
  RecordProperty("plain_within_two", plain_within_two);
  EXPECT_GE(within_two, trials - 2);
  EXPECT_LE(plain_within_two, trials / 2);
}

// What it does not read: no image, colour, a marker past the border, one too large, and a
// flat patch (square and stripe alike).
TEST(ReadRingDeconvolved, RefusesWhatItCannotRead) {
  std::mt19937 rng(6);
  const std::array<Eigen::Vector2d, 4> q = Square(8.5, 0.2);
  const Eigen::Matrix3d H = PixelFromUnit(q);
  const cv::Mat image = RenderMarker(q, Svms44::Codeword(7), 0.7, 2.0, &rng);
  EXPECT_TRUE(ReadRingDeconvolved(image, H).ok);
  EXPECT_FALSE(ReadRingDeconvolved(cv::Mat(), H).ok);
  cv::Mat colour;
  cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(ReadRingDeconvolved(colour, H).ok);
  EXPECT_FALSE(ReadRingDeconvolved(image, PixelFromUnit(Square(8.5, 0.2, 3, 32))).ok);
  EXPECT_FALSE(ReadRingDeconvolved(image(cv::Rect(0, 0, 40, 64)), H).ok);
  RingDeconvolutionOptions small;
  small.max_extent_px = 15;  // the ring's side is 17 px
  EXPECT_FALSE(ReadRingDeconvolved(image, H, small).ok);
  const cv::Mat flat(64, 64, CV_8U, cv::Scalar(128));
  EXPECT_FALSE(ReadRingDeconvolved(flat, H).ok);
  RingDeconvolutionOptions none;
  none.blur_sigmas_px.clear();
  EXPECT_FALSE(ReadRingDeconvolved(image, H, none).ok);
}

// A square of 1 unit tilted by `tilt` radians about its x axis, 2 units in front of a pinhole
// of focal length `focal` px centred at (32, 32): its corners in the order of PixelFromUnit.
// With a focal length of 20 px the square is about 10 px and subtends half a radian, so the
// homography is far from affine (its third row varies by a third across the square).
std::array<Eigen::Vector2d, 4> Tilted(double tilt, double focal = 20) {
  std::array<Eigen::Vector2d, 4> q;
  const double s[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};
  for (int k = 0; k < 4; ++k) {
    const double x = s[k][0], y = s[k][1] * std::cos(tilt), z = 2 + s[k][1] * std::sin(tilt);
    q[k] = Eigen::Vector2d(32 + focal * x / z, 32 - focal * y / z);
  }
  return q;
}

// Strong perspective: the plane's points are divided by the homography's third row, which
// varies across the marker; a reading that left the division out would misplace the far cells.
TEST(ReadRingDeconvolved, ReadsARingSeenInStrongPerspective) {
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> id(0, Svms44::kNumIds - 1);
  for (const double tilt : {0.6, -0.7}) {
    const uint64_t word = Svms44::Codeword(id(rng));
    const std::array<Eigen::Vector2d, 4> q = Tilted(tilt);
    const Eigen::Matrix3d H = PixelFromUnit(q);
    ASSERT_GT(std::abs(H(2, 1)), 0.1);  // not affine
    RingDeconvolutionOptions options;
    options.max_extent_px = 40;  // the ring's near side is 28-31 px
    const RingDeconvolution d =
        ReadRingDeconvolved(RenderMarker(q, word, 0.5, 1.0, &rng), H, options);
    ASSERT_TRUE(d.ok) << tilt;
    EXPECT_LE(Flips(d.word, word), 1) << tilt;
    EXPECT_LT(d.residual_rms, 4) << tilt;
  }
}

// A perspective steep enough to throw the fitted window's corners far beyond a small ring
// (here 144 px across for a ring whose longest side is 33 px) is not read: its cost would grow
// with that area.
TEST(ReadRingDeconvolved, RefusesAWindowThrownFarByPerspective) {
  // Pixels (128 + 5 x / w, 128 - 5 y / w) with w = 1 - 0.7 x: w = 0.3 at the ring's right
  // edge, 0.09 at the window's.
  Eigen::Matrix3d projective, to_centre;
  projective << 5, 0, 0, 0, -5, 0, -0.7, 0, 1;
  to_centre << 1, 0, 128, 0, 1, 128, 0, 0, 1;
  const Eigen::Matrix3d H = to_centre * projective;
  const cv::Mat image(256, 256, CV_8U, cv::Scalar(100));
  RingDeconvolutionOptions options;
  options.max_extent_px = 34;  // the ring passes; the window (up to 68 px) does not
  EXPECT_FALSE(ReadRingDeconvolved(image, H, options).ok);
  EXPECT_EQ(ReadRingDeconvolved(image, H, options).pixels, 0);
  options.max_extent_px = 80;  // a window up to 160 px: fitted (and a flat image then fails)
  const RingDeconvolution d = ReadRingDeconvolved(image, H, options);
  EXPECT_FALSE(d.ok);
  EXPECT_GT(d.pixels, 0);
}

// A deadline already passed stops the reading before its first fit; a far one changes nothing.
TEST(ReadRingDeconvolved, StopsAtADeadline) {
  std::mt19937 rng(7);
  const uint64_t word = Svms44::Codeword(321);
  const std::array<Eigen::Vector2d, 4> q = Square(8.5, 0.4);
  const Eigen::Matrix3d H = PixelFromUnit(q);
  const cv::Mat image = RenderMarker(q, word, 0.7, 2.0, &rng);
  const auto now = std::chrono::steady_clock::now();
  const RingDeconvolution passed = ReadRingDeconvolved(image, H, {}, now);
  EXPECT_TRUE(passed.out_of_time);
  EXPECT_FALSE(passed.ok);
  const RingDeconvolution far = ReadRingDeconvolved(image, H, {}, now + std::chrono::hours(1));
  const RingDeconvolution none = ReadRingDeconvolved(image, H);
  EXPECT_FALSE(far.out_of_time);
  ASSERT_TRUE(far.ok);
  EXPECT_EQ(far.word, none.word);
  EXPECT_EQ(far.word, word);
  EXPECT_EQ(far.blur_sigma_px, none.blur_sigma_px);
}

}  // namespace
}  // namespace svms
