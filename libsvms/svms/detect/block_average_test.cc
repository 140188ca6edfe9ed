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

// Every block sum a block of f x f 8-bit pixels can have, 0 to 255 f^2, one block each: the same
// means as OpenCV's. Laid out in rows of `per_row` blocks (leftover columns and rows left out):
// half the sums a row; 64 a row, which the f = 2 vector loop covers whole at 16, 32 or 64 lanes;
// and one block wide, where every sum goes through its scalar tail.
TEST(BlockAverage, EveryBlockSumRoundsAsOpenCvsAreaResize) {
  for (int f = 2; f <= 4; ++f)
    for (const int layout : {0, 1, 2}) {
      SCOPED_TRACE("f " + std::to_string(f) + ", layout " + std::to_string(layout));
      const int sums = 255 * f * f + 1;
      const int per_row = layout == 0 ? (sums + 1) / 2 : layout == 1 ? 64 : 1;
      const int block_rows = (sums + per_row - 1) / per_row;
      cv::Mat in(block_rows * f + 1, per_row * f + f - 1, CV_8UC1, cv::Scalar(77));
      for (int i = 0; i < sums; ++i) {
        const int s = i, bx = i % per_row, by = i / per_row;
        const int q = s / (f * f), r = s % (f * f);  // r pixels of q + 1, the others q
        for (int p = 0; p < f * f; ++p)
          in.at<uint8_t>(by * f + p / f, bx * f + p % f) = static_cast<uint8_t>(q + (p < r));
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
