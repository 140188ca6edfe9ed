#include "svms/detect/edge_bands.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "svms/detect/canny.h"
#include "svms/detect/worker_pool.h"

namespace svms {
namespace {

// Squares, discs and lines of every grey level on noise: edges that cross the bands' borders
// in every direction, weak edges joined to strong ones across them.
cv::Mat Busy(int cols, int rows, int seed) {
  cv::Mat img(rows, cols, CV_8U);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 90, 110);
  for (int i = 0; i < 60; ++i) {
    const int cy = rng.uniform(0, rows);  // y first, GCC's order: the same images everywhere
    const cv::Point c(rng.uniform(0, cols), cy);
    const int r = rng.uniform(3, 60), grey = rng.uniform(0, 256);
    switch (i % 3) {
      case 0:
        cv::rectangle(img, c, c + cv::Point(r, 2 * r), cv::Scalar(grey), cv::FILLED);
        break;
      case 1:
        cv::circle(img, c, r, cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
        break;
      default:
        cv::line(img, c, c + cv::Point(3 * r, -r), cv::Scalar(grey), 2, cv::LINE_AA);
    }
  }
  // A weak ramp (edges between the thresholds) running down across every band.
  for (int y = 0; y < rows; ++y)
    for (int x = cols / 2; x < cols; ++x)
      img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(img.at<uint8_t>(y, x) + 6);
  return img;
}

TEST(EdgeBands, TheDerivativesAndEdgesAreThoseOfTheSingleThreadedSteps) {
  std::array<uint8_t, 256> sqrt_table;
  const uint8_t* const sqrt_lut = sqrt_table.data();
  for (int v = 0; v < 256; ++v) sqrt_table[v] = cv::saturate_cast<uint8_t>(16 * std::sqrt(v));
  EdgeBandsScratch scratch;
  for (int threads : {2, 3}) {
    WorkerPool pool(threads);
    int k = 0;
    for (const cv::Size size : {cv::Size(640, 480), cv::Size(301, 257), cv::Size(17, 130),
                                cv::Size(64, 3), cv::Size(512, 700)}) {
      const cv::Mat img = Busy(size.width, size.height, 11 + k++);
      for (const uint8_t* table : {static_cast<const uint8_t*>(nullptr), sqrt_lut}) {
        for (const bool l2 : {true, false}) {
          cv::Mat input;  // T(img): a new image (img itself stays the input of the bands)
          if (table) {
            cv::LUT(img, cv::Mat(1, 256, CV_8U, const_cast<uint8_t*>(table)), input);
          } else {
            input = img;
          }
          cv::Mat gx, gy, edges;
          cv::spatialGradient(input, gx, gy, 3);
          CannyScratch canny;
          CannyFromDerivatives(gx, gy, 24, 64, l2, &canny, &edges);
          ASSERT_GT(cv::countNonZero(edges), 0);
          cv::Mat bx, by, bedges;
          ASSERT_TRUE(EdgeMapInBands(img, table, 24, 64, l2, &pool, &scratch, &bx, &by, &bedges));
          const std::string what = std::to_string(size.width) + "x" + std::to_string(size.height) +
                                   " threads " + std::to_string(threads) + (table ? " table" : "") +
                                   (l2 ? " L2" : " L1");
          EXPECT_EQ(cv::norm(gx, bx, cv::NORM_INF), 0) << what;
          EXPECT_EQ(cv::norm(gy, by, cv::NORM_INF), 0) << what;
          EXPECT_EQ(cv::norm(edges, bedges, cv::NORM_INF), 0) << what;
        }
      }
    }
  }
}

TEST(EdgeBands, APassedDeadlineStopsTheBands) {
  WorkerPool pool(2);
  EdgeBandsScratch scratch;
  const cv::Mat img = Busy(640, 480, 3);
  cv::Mat gx, gy, edges;
  EXPECT_FALSE(EdgeMapInBands(img, nullptr, 24, 64, true, &pool, &scratch, &gx, &gy, &edges,
                              std::chrono::steady_clock::now() - std::chrono::seconds(1)));
  EXPECT_TRUE(EdgeMapInBands(img, nullptr, 24, 64, true, &pool, &scratch, &gx, &gy, &edges,
                             std::chrono::steady_clock::now() + std::chrono::hours(1)));
}

}  // namespace
}  // namespace svms
