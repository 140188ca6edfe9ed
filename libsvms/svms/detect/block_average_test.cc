#include "svms/detect/block_average.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace svms {
namespace {

// OpenCV's area resize of the part of `in` that f divides: what BlockAverage must equal.
cv::Mat OpenCvBlocks(const cv::Mat& in, int f) {
  cv::Mat out;
  const int cols = in.cols / f, rows = in.rows / f;
  cv::resize(in(cv::Rect(0, 0, cols * f, rows * f)), out, cv::Size(cols, rows), 0, 0,
             cv::INTER_AREA);
  return out;
}

// Every block sum a block of f x f 8-bit pixels can have, 0 to 255 f^2, one block each (two
// rows of blocks, odd leftover columns and rows left out): the same means as OpenCV's.
TEST(BlockAverage, EveryBlockSumRoundsAsOpenCvsAreaResize) {
  for (int f = 2; f <= 4; ++f) {
    SCOPED_TRACE("f " + std::to_string(f));
    const int sums = 255 * f * f + 1, per_row = (sums + 1) / 2;
    cv::Mat in(2 * f + 1, per_row * f + f - 1, CV_8UC1, cv::Scalar(77));
    for (int s = 0; s < sums; ++s) {
      const int bx = s % per_row, by = s / per_row;
      const int q = s / (f * f), r = s % (f * f);  // r pixels of q + 1, the others q
      for (int i = 0; i < f * f; ++i)
        in.at<uint8_t>(by * f + i / f, bx * f + i % f) = static_cast<uint8_t>(q + (i < r));
    }
    cv::Mat ours;
    ASSERT_TRUE(BlockAverage(in, f, &ours));
    const cv::Mat theirs = OpenCvBlocks(in, f);
    ASSERT_EQ(ours.size(), theirs.size());
    EXPECT_EQ(cv::countNonZero(ours != theirs), 0);
  }
}

// A random image, and the output buffer reused at its size: the same as OpenCV's again.
TEST(BlockAverage, RandomImagesAndAReusedBufferMatchOpenCv) {
  cv::RNG rng(7);
  cv::Mat out;
  for (int f = 2; f <= 4; ++f)
    for (int round = 0; round < 2; ++round) {
      cv::Mat in(203, 317, CV_8UC1);
      rng.fill(in, cv::RNG::UNIFORM, 0, 256);
      const uchar* before = out.data;
      ASSERT_TRUE(BlockAverage(in, f, &out));
      if (round == 1) {
        EXPECT_EQ(out.data, before);  // same size: no new buffer
      }
      EXPECT_EQ(cv::countNonZero(out != OpenCvBlocks(in, f)), 0) << "f " << f;
    }
}

TEST(BlockAverage, RefusesOtherTypesAndFactors) {
  cv::Mat out;
  EXPECT_FALSE(BlockAverage(cv::Mat(8, 8, CV_16UC1, cv::Scalar(1)), 2, &out));
  EXPECT_FALSE(BlockAverage(cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)), 1, &out));
  EXPECT_FALSE(BlockAverage(cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)), 5, &out));
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace svms
