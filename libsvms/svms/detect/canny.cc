#include "svms/detect/canny.h"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <limits>

namespace svms {
namespace {

// Inner loops run over blocks of a fixed number of pixels so that the compiler vectorises
// them even at -O2 (GCC's "very cheap" cost model only vectorises loops whose trip count is
// a known multiple of the vector length); a scalar tail finishes each row.
constexpr int kBlock = 16;

#if defined(__GNUC__) || defined(__clang__)
#define SVMS_CANNY_INLINE inline __attribute__((always_inline))
#else
#define SVMS_CANNY_INLINE inline
#endif

// tan(22.5 deg) in 1/2^15 units, rounded: OpenCV's TG22.
constexpr int32_t kTan22 = 13573;

// Map values, as in OpenCV: 0 a surviving pixel not (yet) known to be an edge, 1 never an
// edge, 2 an edge.
constexpr uint8_t kCandidate = 0, kNotEdge = 1, kEdge = 2;

// Grows `v` to at least `n` elements; never shrinks it, never reallocates when capacity
// suffices.
template <typename T>
void GrowTo(std::vector<T>* v, size_t n) {
  if (v->size() < n) v->resize(n);
}

// out[j] = dx[j]^2 + dy[j]^2 for j in [0, n), summed in 32 bits and wrapping as OpenCV's
// (only (-32768, -32768) overflows).
void MagnitudeL2(const int16_t* __restrict dx, const int16_t* __restrict dy,
                 int32_t* __restrict out, int n) {
  auto pixel = [&](int j) {
    const int32_t x = dx[j], y = dy[j];
    return static_cast<int32_t>(static_cast<uint32_t>(x * x) + static_cast<uint32_t>(y * y));
  };
  int j = 0;
  for (; j + kBlock <= n; j += kBlock)
    for (int k = 0; k < kBlock; ++k) out[j + k] = pixel(j + k);
  for (; j < n; ++j) out[j] = pixel(j);
}

// out[j] = |dx[j]| + |dy[j]| for j in [0, n).
void MagnitudeL1(const int16_t* __restrict dx, const int16_t* __restrict dy,
                 int32_t* __restrict out, int n) {
  auto pixel = [&](int j) {
    const int32_t x = dx[j], y = dy[j];
    return (x < 0 ? -x : x) + (y < 0 ? -y : y);
  };
  int j = 0;
  for (; j + kBlock <= n; j += kBlock)
    for (int k = 0; k < kBlock; ++k) out[j + k] = pixel(j + k);
  for (; j < n; ++j) out[j] = pixel(j);
}

// Non-maximum suppression and double threshold of pixel j of a row: kEdge, kCandidate or
// kNotEdge. `above`, `here`, `below` are the magnitudes of the rows before, at and after this
// one, readable at [j - 1, j + 1] (zero outside the image); `dx`, `dy` this row's derivatives.
// Branch-free: every neighbour is loaded and the one OpenCV's direction test picks is
// selected. Gives kNotEdge at or below `low`, so it may be called for any pixel.
SVMS_CANNY_INLINE uint8_t SuppressPixel(const int32_t* above, const int32_t* here,
                                        const int32_t* below, const int16_t* dx, const int16_t* dy,
                                        int32_t low, int32_t high, int j) {
  const int32_t m = here[j], left = here[j - 1], right = here[j + 1];
  const int32_t up_left = above[j - 1], up = above[j], up_right = above[j + 1];
  const int32_t down_left = below[j - 1], down = below[j], down_right = below[j + 1];
  const int32_t xs = dx[j], ys = dy[j];
  const int32_t x = xs < 0 ? -xs : xs;
  const int32_t y = (ys < 0 ? -ys : ys) << 15;  // at most 2^30
  const int32_t tg22x = x * kTan22;             // below 2^31
  // OpenCV's tg22x + (x << 16) in 32 bits; wraps for x > ~25,000 as OpenCV's does.
  const int32_t tg67x =
      static_cast<int32_t>(static_cast<uint32_t>(tg22x) + (static_cast<uint32_t>(x) << 16));
  const bool horizontal = y < tg22x;
  const bool vertical = !horizontal & (y > tg67x);
  const bool diagonal = !horizontal & !vertical;
  // Diagonal: OpenCV's s = sign(dx dy) compares above[j - s] and below[j + s].
  const bool falling = (xs ^ ys) < 0;  // s == -1
  const int32_t diagonal_before = falling ? up_right : up_left;
  const int32_t diagonal_after = falling ? down_left : down_right;
  const int32_t before = horizontal ? left : vertical ? up : diagonal_before;
  const int32_t after = horizontal ? right : vertical ? down : diagonal_after;
  // Ties: a plateau along the gradient keeps its first pixel (>= after), except diagonally.
  const bool peak = (m > low) & (m > before) & ((m > after) | (!diagonal & (m == after)));
  return peak ? (m > high ? kEdge : kCandidate) : kNotEdge;
}

// Pixels above `low` in a block from which SuppressRow tests every pixel of the block without
// a branch. Where few pixels are above `low` (most of a frame of markers) a branch per pixel
// is cheaper than testing all 16; on texture (foliage, gravel: most pixels above `low`) that
// branch goes either way at random and costs more than the test it skips. The value was chosen
// by timing the crops of `svms bench speed`; it changes no output.
constexpr int kDenseBlock = kBlock / 4;

// SuppressPixel for j in [0, n), into out[j]: blocks with no magnitude above `low` are
// written kNotEdge at once, blocks with few are tested pixel by pixel where above `low`, and
// blocks with many at every pixel, without branches.
void SuppressRow(const int32_t* __restrict above, const int32_t* __restrict here,
                 const int32_t* __restrict below, const int16_t* __restrict dx,
                 const int16_t* __restrict dy, int32_t low, int32_t high, uint8_t* __restrict out,
                 int n) {
  int j = 0;
  for (; j + kBlock <= n; j += kBlock) {
    // Most of an image is flat: a block with no magnitude above `low` has no edge pixel and
    // needs no direction test (this makes the detector's edge stage 2x faster on sparse frames).
    int32_t count = 0;
    for (int k = 0; k < kBlock; ++k) count += here[j + k] > low;
    if (count == 0) {
      std::memset(out + j, kNotEdge, kBlock);
    } else if (count >= kDenseBlock) {
      for (int k = 0; k < kBlock; ++k)
        out[j + k] = SuppressPixel(above, here, below, dx, dy, low, high, j + k);
    } else {
      for (int k = j; k < j + kBlock; ++k)
        out[k] = here[k] > low ? SuppressPixel(above, here, below, dx, dy, low, high, k) : kNotEdge;
    }
  }
  for (; j < n; ++j) out[j] = SuppressPixel(above, here, below, dx, dy, low, high, j);
}

// Appends to `stack` (at `*top`) the offsets, relative to `base`, of the kEdge pixels among
// row[0, n). Edge pixels are usually sparse: whole 8-byte words without a 2 are skipped.
void PushEdges(const uint8_t* row, int n, const uint8_t* base, int32_t* stack, size_t* top) {
  const int32_t offset = static_cast<int32_t>(row - base);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    uint64_t word;
    std::memcpy(&word, row + j, 8);
    if (!(word & 0x0202020202020202ull)) continue;  // kEdge is the only value with bit 1
    for (int k = j; k < j + 8; ++k)
      if (row[k] == kEdge) stack[(*top)++] = offset + k;
  }
  for (; j < n; ++j)
    if (row[j] == kEdge) stack[(*top)++] = offset + j;
}

// edges[j] = 255 where map[j] is kEdge, else 0 (OpenCV's -(map >> 1)).
void FinalRow(const uint8_t* __restrict map, uint8_t* __restrict edges, int n) {
  auto pixel = [&](int j) { return static_cast<uint8_t>(map[j] == kEdge ? 255 : 0); };
  int j = 0;
  for (; j + kBlock <= n; j += kBlock)
    for (int k = 0; k < kBlock; ++k) edges[j + k] = pixel(j + k);
  for (; j < n; ++j) edges[j] = pixel(j);
}

// Thresholds exactly as cv::Canny(dx, dy, ...) turns them into integers.
void IntegerThresholds(double low, double high, bool l2_gradient, int32_t* ilow, int32_t* ihigh) {
  if (low > high) std::swap(low, high);
  if (l2_gradient) {
    low = std::min(32767.0, low);
    high = std::min(32767.0, high);
    if (low > 0) low *= low;
    if (high > 0) high *= high;
  }
  *ilow = cvFloor(low);
  *ihigh = cvFloor(high);
}

}  // namespace

namespace canny_rows {

void Thresholds(double low, double high, bool l2_gradient, int32_t* ilow, int32_t* ihigh) {
  IntegerThresholds(low, high, l2_gradient, ilow, ihigh);
}

void Magnitude(const int16_t* dx, const int16_t* dy, bool l2_gradient, int32_t* out, int n) {
  if (l2_gradient) {
    MagnitudeL2(dx, dy, out, n);
  } else {
    MagnitudeL1(dx, dy, out, n);
  }
}

void SuppressRow(const int32_t* above, const int32_t* here, const int32_t* below, const int16_t* dx,
                 const int16_t* dy, int32_t low, int32_t high, uint8_t* out, int n) {
  svms::SuppressRow(above, here, below, dx, dy, low, high, out, n);
}

void PushEdges(const uint8_t* row, int n, const uint8_t* base, int32_t* stack, size_t* top) {
  svms::PushEdges(row, n, base, stack, top);
}

bool Hysteresis(uint8_t* map, int cols, int32_t* stack, size_t top, int32_t begin, int32_t end,
                std::chrono::steady_clock::time_point deadline) {
  const bool has_deadline = deadline != std::chrono::steady_clock::time_point::max();
  const ptrdiff_t s = static_cast<ptrdiff_t>(cols) + 2;
  const ptrdiff_t neighbours[8] = {-s - 1, -s, -s + 1, -1, 1, s - 1, s, s + 1};
  for (uint32_t popped = 1; top > 0; ++popped) {
    if (popped % 4096 == 0 && has_deadline && std::chrono::steady_clock::now() >= deadline)
      return false;
    const int32_t at = stack[--top];
    for (const ptrdiff_t d : neighbours) {
      const ptrdiff_t q = at + d;
      if (q >= begin && q < end && map[q] == kCandidate) {
        map[q] = kEdge;
        stack[top++] = static_cast<int32_t>(q);
      }
    }
  }
  return true;
}

void FinalRow(const uint8_t* map, uint8_t* edges, int n) { svms::FinalRow(map, edges, n); }

}  // namespace canny_rows

bool CannyFromDerivatives(const cv::Mat& dx_in, const cv::Mat& dy_in, double low, double high,
                          bool l2_gradient, CannyScratch* scratch, cv::Mat* edges,
                          std::chrono::steady_clock::time_point deadline) {
  const bool has_deadline = deadline != std::chrono::steady_clock::time_point::max();
  auto past = [&] { return has_deadline && std::chrono::steady_clock::now() >= deadline; };
  // The same checks as cv::Canny. Headers are copied (no allocation) so that `edges` may even
  // be one of the inputs.
  CV_Assert(dx_in.dims == 2);
  CV_Assert(dx_in.type() == CV_16SC1);
  CV_Assert(dy_in.type() == dx_in.type());
  CV_Assert(dx_in.size == dy_in.size);
  const cv::Mat dx = dx_in, dy = dy_in;
  const int rows = dx.rows, cols = dx.cols;
  edges->create(rows, cols, CV_8UC1);
  if (rows == 0 || cols == 0) return true;

  int32_t ilow, ihigh;
  IntegerThresholds(low, high, l2_gradient, &ilow, &ihigh);

  const size_t stride = static_cast<size_t>(cols) + 2;  // map and magnitude rows
  const size_t map_size = stride * (static_cast<size_t>(rows) + 2);
  CV_Assert(map_size <= static_cast<size_t>(std::numeric_limits<int32_t>::max()));
  GrowTo(&scratch->magnitude, 3 * stride);
  GrowTo(&scratch->map, map_size);
  GrowTo(&scratch->stack, static_cast<size_t>(rows) * cols);  // each pixel is pushed once at most

  // Magnitude rows have a zero pad on either side: [-1] and [cols] read as 0.
  int32_t* ring[3] = {scratch->magnitude.data() + 1, scratch->magnitude.data() + 1 + stride,
                      scratch->magnitude.data() + 1 + 2 * stride};
  auto magnitude = [&](int y, int32_t* out) {
    if (y >= rows) {
      std::fill(out, out + cols, 0);
    } else if (l2_gradient) {
      MagnitudeL2(dx.ptr<int16_t>(y), dy.ptr<int16_t>(y), out, cols);
    } else {
      MagnitudeL1(dx.ptr<int16_t>(y), dy.ptr<int16_t>(y), out, cols);
    }
  };
  for (int32_t* r : ring) r[-1] = r[cols] = 0;
  int32_t *above = ring[0], *here = ring[1], *below = ring[2];
  std::fill(above, above + cols, 0);
  magnitude(0, here);
  magnitude(1, below);

  uint8_t* map = scratch->map.data();
  std::memset(map, kNotEdge, stride);
  std::memset(map + stride * (rows + 1), kNotEdge, stride);
  int32_t* stack = scratch->stack.data();
  size_t top = 0;
  for (int y = 0; y < rows; ++y) {
    if (y % 64 == 63 && past()) return false;
    uint8_t* row = map + stride * (y + 1) + 1;
    row[-1] = row[cols] = kNotEdge;
    SuppressRow(above, here, below, dx.ptr<int16_t>(y), dy.ptr<int16_t>(y), ilow, ihigh, row, cols);
    PushEdges(row, cols, map, stack, &top);
    int32_t* spare = above;
    above = here;
    here = below;
    below = spare;
    magnitude(y + 2, below);
  }

  // Hysteresis: candidates 8-connected to an edge become edges. A pixel is pushed only when
  // it turns into kEdge, so the stack never holds more than rows * cols offsets.
  const ptrdiff_t s = static_cast<ptrdiff_t>(stride);
  const ptrdiff_t neighbours[8] = {-s - 1, -s, -s + 1, -1, 1, s - 1, s, s + 1};
  for (uint32_t popped = 1; top > 0; ++popped) {
    if (popped % 4096 == 0 && past()) return false;
    const int32_t at = stack[--top];
    uint8_t* m = map + at;
    for (const ptrdiff_t d : neighbours) {
      if (m[d] == kCandidate) {
        m[d] = kEdge;
        stack[top++] = static_cast<int32_t>(at + d);
      }
    }
  }

  for (int y = 0; y < rows; ++y) {
    if (y % 64 == 63 && past()) return false;
    FinalRow(map + stride * (y + 1) + 1, edges->ptr<uint8_t>(y), cols);
  }
  return true;
}

}  // namespace svms
