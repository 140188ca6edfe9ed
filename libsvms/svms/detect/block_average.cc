#include "svms/detect/block_average.h"

#include <cstdint>
#include <opencv2/core/hal/intrin.hpp>

namespace svms {
namespace {

// A block's sum s of F x F pixels to its rounded mean, as OpenCV's area resize rounds it.
template <int F>
inline uint8_t RoundedMean(int s) {
  if constexpr (F == 2) return static_cast<uint8_t>((s + 2) >> 2);  // halves up
  if constexpr (F == 3) return static_cast<uint8_t>((s + 4) / 9);   // s / 9 is never a half
  if constexpr (F == 4) return static_cast<uint8_t>((s + 7 + ((s >> 4) & 1)) >> 4);  // to even
}

// Each output pixel from its F x F block, F a constant so that the sums unroll.
template <int F>
void Average(const cv::Mat& in, cv::Mat* out) {
  const int cols = out->cols;
  for (int y = 0; y < out->rows; ++y) {
    const uint8_t* row[F];
    for (int k = 0; k < F; ++k) row[k] = in.ptr<uint8_t>(F * y + k);
    uint8_t* dst = out->ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      int s = 0;
      for (int k = 0; k < F; ++k)
        for (int j = 0; j < F; ++j) s += row[k][F * x + j];
      dst[x] = RoundedMean<F>(s);
    }
  }
}

// F = 2, the decimation used most, with OpenCV's universal intrinsics (the compiler does not
// vectorise the even/odd pairs of Average<2>): the same sums and rounding, lanes at a time.
void Average2(const cv::Mat& in, cv::Mat* out) {
  const int cols = out->cols;
  for (int y = 0; y < out->rows; ++y) {
    const uint8_t* r0 = in.ptr<uint8_t>(2 * y);
    const uint8_t* r1 = in.ptr<uint8_t>(2 * y + 1);
    uint8_t* dst = out->ptr<uint8_t>(y);
    int x = 0;
#if CV_SIMD
    const cv::v_uint16 two = cv::vx_setall_u16(2);
    for (; x + cv::v_uint8::nlanes <= cols; x += cv::v_uint8::nlanes) {
      cv::v_uint8 a_even, a_odd, b_even, b_odd;
      cv::v_load_deinterleave(r0 + 2 * x, a_even, a_odd);
      cv::v_load_deinterleave(r1 + 2 * x, b_even, b_odd);
      cv::v_uint16 a_even_lo, a_even_hi, a_odd_lo, a_odd_hi, b_even_lo, b_even_hi, b_odd_lo,
          b_odd_hi;
      cv::v_expand(a_even, a_even_lo, a_even_hi);
      cv::v_expand(a_odd, a_odd_lo, a_odd_hi);
      cv::v_expand(b_even, b_even_lo, b_even_hi);
      cv::v_expand(b_odd, b_odd_lo, b_odd_hi);
      const cv::v_uint16 lo = cv::v_shr<2>(a_even_lo + a_odd_lo + b_even_lo + b_odd_lo + two);
      const cv::v_uint16 hi = cv::v_shr<2>(a_even_hi + a_odd_hi + b_even_hi + b_odd_hi + two);
      cv::v_store(dst + x, cv::v_pack(lo, hi));
    }
#endif
    for (; x < cols; ++x)
      dst[x] = RoundedMean<2>(r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
  }
}

}  // namespace

bool BlockAverage(const cv::Mat& in, int f, cv::Mat* out) {
  if (in.type() != CV_8UC1 || f < 2 || f > 4) return false;
  out->create(in.rows / f, in.cols / f, CV_8UC1);
  if (f == 2) Average2(in, out);
  if (f == 3) Average<3>(in, out);
  if (f == 4) Average<4>(in, out);
  return true;
}

}  // namespace svms
