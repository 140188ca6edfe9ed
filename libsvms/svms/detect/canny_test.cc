// CannyFromDerivatives against OpenCV 4.6's cv::Canny(dx, dy, ...), pixel for pixel.
#include "svms/detect/canny.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace svms {
namespace {

struct Thresholds {
  double low, high;
};

// Threshold pairs: the detector's (24, 64), swapped, zero, equal, fractional (cvFloor, and
// squared before flooring with L2), negative, large, and beyond the L2 clamp at 32767.
const std::vector<Thresholds> kThresholds = {
    {24, 64}, {64, 24}, {0, 0},     {0, 50},      {10, 10},       {5.5, 20.7},
    {-3, 40}, {-9, -2}, {100, 300}, {1000, 3000}, {40000, 50000}, {200.25, 200.75}};

// Where the two maps differ, or "" when they are equal.
std::string Difference(const cv::Mat& expected, const cv::Mat& actual) {
  if (expected.size() != actual.size() || expected.type() != actual.type())
    return "size or type differs";
  for (int y = 0; y < expected.rows; ++y)
    for (int x = 0; x < expected.cols; ++x)
      if (expected.at<uint8_t>(y, x) != actual.at<uint8_t>(y, x))
        return "first difference at x " + std::to_string(x) + ", y " + std::to_string(y) +
               " (OpenCV " + std::to_string(expected.at<uint8_t>(y, x)) + ")";
  return "";
}

// Runs both on (dx, dy) with every threshold pair and both L2 settings.
void ExpectSameAsOpenCV(const cv::Mat& dx, const cv::Mat& dy, const std::string& what,
                        CannyScratch* scratch) {
  for (const Thresholds& t : kThresholds)
    for (const bool l2 : {true, false}) {
      cv::Mat expected, actual;
      cv::Canny(dx, dy, expected, t.low, t.high, l2);
      CannyFromDerivatives(dx, dy, t.low, t.high, l2, scratch, &actual);
      EXPECT_EQ(Difference(expected, actual), "")
          << what << " " << dx.cols << " x " << dx.rows << ", low " << t.low << ", high " << t.high
          << (l2 ? ", L2" : ", L1");
    }
}

void ExpectSameAsOpenCV(const cv::Mat& dx, const cv::Mat& dy, const std::string& what) {
  CannyScratch scratch;
  ExpectSameAsOpenCV(dx, dy, what, &scratch);
}

void Derivatives(const cv::Mat& img, cv::Mat* dx, cv::Mat* dy) {
  cv::spatialGradient(img, *dx, *dy, 3);
}

cv::Mat Noise(cv::Size size, uint64_t seed) {
  cv::Mat img(size, CV_8U);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  return img;
}

// Slow ramps and ripples: long plateaus and ties between neighbours.
cv::Mat Smooth(cv::Size size) {
  cv::Mat img(size, CV_8U);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
          128 + 0.3 * x - 0.2 * y + 60 * std::sin(x * 0.05) * std::cos(y * 0.07));
  return img;
}

// Dark rotated squares on a light background, blurred a little, with noise: what the
// detector sees.
cv::Mat Squares(cv::Size size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(size, CV_8U, cv::Scalar(200));
  const int count = std::max(1, size.area() / 4000);
  for (int k = 0; k < count; ++k) {
    // One draw per statement, y first (GCC's order for the two-argument form): the same images
    // under every compiler.
    const float cy = rng.uniform(0.f, static_cast<float>(size.height));
    const float cx = rng.uniform(0.f, static_cast<float>(size.width));
    const cv::Point2f centre(cx, cy);
    const float side = rng.uniform(6.f, 80.f), angle = rng.uniform(0.f, 90.f);
    cv::Point2f corners[4];
    cv::RotatedRect(centre, cv::Size2f(side, side), angle).points(corners);
    std::vector<cv::Point> poly;
    for (const cv::Point2f& c : corners) poly.emplace_back(cvRound(c.x * 16), cvRound(c.y * 16));
    cv::fillConvexPoly(img, poly, cv::Scalar(rng.uniform(10, 120)), cv::LINE_AA, 4);
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  cv::Mat noise(size, CV_16S);
  rng.fill(noise, cv::RNG::NORMAL, 0, 4);
  cv::Mat out;
  cv::add(img, noise, out, cv::noArray(), CV_8U);
  return out;
}

// The detector's edge input: 16 sqrt(grey), as in segments.cc.
cv::Mat StabiliseVariance(const cv::Mat& gray8) {
  cv::Mat lut(1, 256, CV_8U);
  for (int v = 0; v < 256; ++v) lut.at<uint8_t>(v) = cv::saturate_cast<uint8_t>(16 * std::sqrt(v));
  cv::Mat out;
  cv::LUT(gray8, lut, out);
  return out;
}

const std::vector<cv::Size> kSizes = {
    {1, 1},   {7, 1},   {1, 7},   {2, 2},   {3, 5},     {5, 3},     {4, 4},
    {15, 1},  {1, 15},  {16, 16}, {17, 2},  {2, 17},    {33, 17},   {31, 64},
    {100, 3}, {3, 100}, {64, 64}, {97, 89}, {640, 480}, {641, 479}, {479, 641}};

TEST(Canny, SameAsOpenCVOnNoise) {
  for (const cv::Size& size : kSizes) {
    cv::Mat dx, dy;
    Derivatives(Noise(size, 1 + size.area()), &dx, &dy);
    ExpectSameAsOpenCV(dx, dy, "noise");
  }
}

TEST(Canny, SameAsOpenCVOnSmoothGradients) {
  for (const cv::Size& size : kSizes) {
    cv::Mat dx, dy;
    Derivatives(Smooth(size), &dx, &dy);
    ExpectSameAsOpenCV(dx, dy, "smooth");
  }
}

TEST(Canny, SameAsOpenCVOnSquares) {
  for (const cv::Size& size : kSizes) {
    cv::Mat dx, dy;
    Derivatives(Squares(size, 7 + size.area()), &dx, &dy);
    ExpectSameAsOpenCV(dx, dy, "squares");
  }
}

TEST(Canny, SameAsOpenCVOnConstantImages) {
  for (const cv::Size& size : {cv::Size(1, 1), cv::Size(2, 2), cv::Size(40, 30)}) {
    cv::Mat dx, dy;
    Derivatives(cv::Mat(size, CV_8U, cv::Scalar(77)), &dx, &dy);
    ExpectSameAsOpenCV(dx, dy, "constant");
  }
}

// 1024 x 1024: the detector's frame size, with OpenCV splitting the image between threads.
TEST(Canny, SameAsOpenCVOnLargeFrames) {
  const cv::Size size(1024, 1024);
  CannyScratch scratch;
  cv::Mat dx, dy;
  Derivatives(Squares(size, 11), &dx, &dy);
  ExpectSameAsOpenCV(dx, dy, "squares", &scratch);
  Derivatives(Noise(size, 12), &dx, &dy);
  ExpectSameAsOpenCV(dx, dy, "noise", &scratch);
}

// What segments.cc does: spatialGradient of 16 sqrt(grey), low 24, high 64, L2.
TEST(Canny, SameAsOpenCVWithTheDetectorsThresholds) {
  CannyScratch scratch;
  for (const cv::Size& size : {cv::Size(1024, 1024), cv::Size(641, 479), cv::Size(7, 1)}) {
    for (const uint64_t seed : {21, 22}) {
      cv::Mat dx, dy, expected, actual;
      Derivatives(StabiliseVariance(Squares(size, seed)), &dx, &dy);
      cv::Canny(dx, dy, expected, 24, 64, true);
      CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &actual);
      EXPECT_EQ(Difference(expected, actual), "") << size;
      if (size.area() > 1000) {
        EXPECT_GT(cv::countNonZero(expected), 1000);  // not a trivial map
      }
    }
  }
}

// OpenCV's result does not depend on its thread count (slices meet at rows it hands to a
// final serial hysteresis); check against the single-threaded run too.
TEST(Canny, SameAsSingleThreadedOpenCV) {
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  for (const cv::Size& size : {cv::Size(641, 479), cv::Size(2, 2)}) {
    cv::Mat dx, dy;
    Derivatives(Squares(size, 31), &dx, &dy);
    ExpectSameAsOpenCV(dx, dy, "squares, 1 thread");
  }
  cv::setNumThreads(threads);
}

// Derivatives that are views into larger matrices (rows not contiguous), and edges written
// into a view of a larger map.
TEST(Canny, SameAsOpenCVOnRegionsOfInterest) {
  cv::Mat dx, dy;
  Derivatives(Squares(cv::Size(300, 200), 41), &dx, &dy);
  for (const cv::Rect roi :
       {cv::Rect(3, 5, 101, 77), cv::Rect(0, 0, 1, 1), cv::Rect(299, 0, 1, 200),
        cv::Rect(10, 199, 290, 1), cv::Rect(1, 1, 2, 2), cv::Rect(0, 0, 300, 199)}) {
    ASSERT_TRUE(roi.width == 300 || !dx(roi).isContinuous() || roi.height == 1);
    ExpectSameAsOpenCV(dx(roi), dy(roi), "roi");
  }
  // Output into a view: it is kept (same size and type) and only the view is written.
  cv::Mat big_expected(250, 350, CV_8U, cv::Scalar(9)), big_actual = big_expected.clone();
  const cv::Rect roi(20, 30, 101, 77);
  cv::Mat expected = big_expected(roi), actual = big_actual(roi);
  cv::Canny(dx(roi), dy(roi), expected, 24, 64, true);
  CannyScratch scratch;
  CannyFromDerivatives(dx(roi), dy(roi), 24, 64, true, &scratch, &actual);
  EXPECT_EQ(actual.data, big_actual.ptr(30, 20));
  EXPECT_EQ(Difference(big_expected, big_actual), "");
}

// Derivatives of any 16-bit value: the L2 magnitude's overflow at (-32768, -32768) and the
// wrapping of OpenCV's 67.5-degree bound for |dx| above about 25,000.
TEST(Canny, SameAsOpenCVOnFullRangeDerivatives) {
  cv::RNG rng(51);
  for (const cv::Size& size : {cv::Size(257, 131), cv::Size(16, 16), cv::Size(5, 3)}) {
    cv::Mat dx(size, CV_16S), dy(size, CV_16S);
    // L2 on the full range (including -32768), with and without smoothing between pixels.
    rng.fill(dx, cv::RNG::UNIFORM, -32768, 32768);
    rng.fill(dy, cv::RNG::UNIFORM, -32768, 32768);
    dx.at<int16_t>(size.height / 2, size.width / 2) = -32768;
    dy.at<int16_t>(size.height / 2, size.width / 2) = -32768;
    for (const Thresholds& t : kThresholds) {
      cv::Mat expected, actual;
      CannyScratch scratch;
      cv::Canny(dx, dy, expected, t.low * 100, t.high * 100, true);
      CannyFromDerivatives(dx, dy, t.low * 100, t.high * 100, true, &scratch, &actual);
      EXPECT_EQ(Difference(expected, actual), "") << "L2 " << size << " " << t.low;
    }
    // L1: OpenCV's SIMD 16-bit abs takes |-32768| as -32768 (see canny.h), so stay above.
    rng.fill(dx, cv::RNG::UNIFORM, -32767, 32768);
    rng.fill(dy, cv::RNG::UNIFORM, -32767, 32768);
    ExpectSameAsOpenCV(dx, dy, "full range L1, and L2");
    cv::Mat dx_blur, dy_blur;
    cv::blur(dx, dx_blur, cv::Size(5, 5));
    cv::blur(dy, dy_blur, cv::Size(5, 5));
    ExpectSameAsOpenCV(dx_blur, dy_blur, "full range blurred");
  }
}

TEST(Canny, EmptyAndInvalidInputsAreTreatedAsOpenCVDoes) {
  CannyScratch scratch;
  cv::Mat edges;
  const cv::Mat rows0(0, 5, CV_16S), cols0(5, 0, CV_16S);
  for (const cv::Mat& empty : {rows0, cols0}) {
    cv::Mat expected;
    cv::Canny(empty, empty, expected, 1, 2, true);
    CannyFromDerivatives(empty, empty, 1, 2, true, &scratch, &edges);
    EXPECT_EQ(edges.size(), expected.size());
    EXPECT_EQ(edges.type(), CV_8UC1);
  }
  EXPECT_THROW(CannyFromDerivatives(cv::Mat(), cv::Mat(), 1, 2, true, &scratch, &edges),
               cv::Exception);
  EXPECT_THROW(CannyFromDerivatives(cv::Mat(4, 4, CV_16S), cv::Mat(4, 5, CV_16S), 1, 2, true,
                                    &scratch, &edges),
               cv::Exception);
  EXPECT_THROW(CannyFromDerivatives(cv::Mat(4, 4, CV_32F), cv::Mat(4, 4, CV_32F), 1, 2, true,
                                    &scratch, &edges),
               cv::Exception);
}

// The scratch reaches its size on the first call; later calls on images no larger reuse it
// and the edge map (a proxy for "allocates nothing": see the malloc count in the report).
TEST(Canny, LaterCallsReuseEveryBuffer) {
  CannyScratch scratch;
  cv::Mat dx, dy, edges;
  Derivatives(StabiliseVariance(Squares(cv::Size(1024, 1024), 61)), &dx, &dy);
  CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &edges);
  const void* data[] = {scratch.magnitude.data(), scratch.map.data(), scratch.stack.data(),
                        edges.data};
  const size_t capacity[] = {scratch.magnitude.capacity(), scratch.map.capacity(),
                             scratch.stack.capacity()};
  auto expect_unchanged = [&](const std::string& what) {
    EXPECT_EQ(scratch.magnitude.data(), data[0]) << what;
    EXPECT_EQ(scratch.map.data(), data[1]) << what;
    EXPECT_EQ(scratch.stack.data(), data[2]) << what;
    EXPECT_EQ(scratch.magnitude.capacity(), capacity[0]) << what;
    EXPECT_EQ(scratch.map.capacity(), capacity[1]) << what;
    EXPECT_EQ(scratch.stack.capacity(), capacity[2]) << what;
  };
  for (int call = 0; call < 3; ++call) {
    Derivatives(StabiliseVariance(Squares(cv::Size(1024, 1024), 62 + call)), &dx, &dy);
    CannyFromDerivatives(dx, dy, 24, 64, call != 1, &scratch, &edges);
    expect_unchanged("call " + std::to_string(call));
    EXPECT_EQ(static_cast<const void*>(edges.data), data[3]);
  }
  // A smaller image reuses the scratch too (the edge map is resized by its owner).
  cv::Mat small_edges;
  Derivatives(Noise(cv::Size(300, 1000), 65), &dx, &dy);
  CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &small_edges);
  expect_unchanged("smaller image");
  cv::Mat expected;
  cv::Canny(dx, dy, expected, 24, 64, true);
  EXPECT_EQ(Difference(expected, small_edges), "");  // stale scratch contents do not matter
}

TEST(Canny, APassedDeadlineStopsTheMapAndAFarOneChangesNothing) {
  cv::Mat dx, dy;
  Derivatives(Noise(cv::Size(300, 200), 4), &dx, &dy);
  CannyScratch scratch;
  cv::Mat whole, again;
  ASSERT_TRUE(CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &whole));
  const auto now = std::chrono::steady_clock::now();
  EXPECT_FALSE(
      CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &again, now - std::chrono::seconds(1)));
  ASSERT_TRUE(
      CannyFromDerivatives(dx, dy, 24, 64, true, &scratch, &again, now + std::chrono::hours(1)));
  EXPECT_EQ(Difference(whole, again), "");
}

}  // namespace
}  // namespace svms
