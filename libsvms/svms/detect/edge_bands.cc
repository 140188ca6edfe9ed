#include "svms/detect/edge_bands.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "svms/detect/canny.h"
#include "svms/detect/worker_pool.h"

namespace svms {
namespace {

using Clock = std::chrono::steady_clock;
namespace cr = canny_rows;

// Pixels per block of the inner loops: a trip count the compiler vectorises at -O2 (canny.cc).
constexpr int kBlock = 16;

template <typename T>
void GrowTo(std::vector<T>* v, size_t n) {
  if (v->size() < n) v->resize(n);
}

// cv::spatialGradient's 3x3 Sobel derivatives of one row from the rows above (`a`), at (`b`)
// and below (`c`) it, with its border (reflected about the first and last columns, OpenCV's
// BORDER_REFLECT_101). cols >= 2.
void SobelRow(const uint8_t* __restrict a, const uint8_t* __restrict b, const uint8_t* __restrict c,
              int cols, int16_t* __restrict dx, int16_t* __restrict dy) {
  const int last = cols - 1;
  dx[0] = static_cast<int16_t>(0);  // reflected: the pixels left and right of x = 0 are equal
  dy[0] = static_cast<int16_t>((c[1] + 2 * c[0] + c[1]) - (a[1] + 2 * a[0] + a[1]));
  int x = 1;
  for (; x + kBlock <= last; x += kBlock) {
    for (int k = 0; k < kBlock; ++k) {
      const int j = x + k;
      dx[j] = static_cast<int16_t>((a[j + 1] - a[j - 1]) + 2 * (b[j + 1] - b[j - 1]) +
                                   (c[j + 1] - c[j - 1]));
      dy[j] =
          static_cast<int16_t>((c[j - 1] + 2 * c[j] + c[j + 1]) - (a[j - 1] + 2 * a[j] + a[j + 1]));
    }
  }
  for (; x < last; ++x) {
    dx[x] = static_cast<int16_t>((a[x + 1] - a[x - 1]) + 2 * (b[x + 1] - b[x - 1]) +
                                 (c[x + 1] - c[x - 1]));
    dy[x] =
        static_cast<int16_t>((c[x - 1] + 2 * c[x] + c[x + 1]) - (a[x - 1] + 2 * a[x] + a[x + 1]));
  }
  dx[last] = 0;
  dy[last] = static_cast<int16_t>((c[last - 1] + 2 * c[last] + c[last - 1]) -
                                  (a[last - 1] + 2 * a[last] + a[last - 1]));
}

// Rows [y0, y1) of the map: the table, the derivatives (into gx, gy), the magnitudes,
// non-maximum suppression and the band's own hysteresis. False when `deadline` passed.
bool BandEdges(const cv::Mat& gray8, const uint8_t* table, int32_t low, int32_t high, bool l2,
               Clock::time_point deadline, EdgeBandsScratch::Band* band, uint8_t* map, cv::Mat* gx,
               cv::Mat* gy) {
  const bool has_deadline = deadline != Clock::time_point::max();
  const int rows = gray8.rows, cols = gray8.cols, y0 = band->y0, y1 = band->y1;
  const size_t stride = static_cast<size_t>(cols) + 2;
  GrowTo(&band->table_rows, 3 * static_cast<size_t>(cols));
  GrowTo(&band->border_dx, 2 * static_cast<size_t>(cols));
  GrowTo(&band->border_dy, 2 * static_cast<size_t>(cols));
  GrowTo(&band->magnitude, 3 * stride);
  GrowTo(&band->stack, static_cast<size_t>(y1 - y0) * cols);

  // Row r of the table's image (reflected at the top and bottom, as Sobel's border is), in
  // slot `slot` of the band's three rows when there is a table.
  auto source = [&](int r, int slot) -> const uint8_t* {
    r = cv::borderInterpolate(r, rows, cv::BORDER_REFLECT_101);
    const uint8_t* in = gray8.ptr<uint8_t>(r);
    if (!table) return in;
    uint8_t* out = band->table_rows.data() + static_cast<size_t>(slot) * cols;
    int x = 0;
    for (; x + 4 <= cols; x += 4) {
      const uint8_t p = table[in[x]], q = table[in[x + 1]], s = table[in[x + 2]],
                    t = table[in[x + 3]];
      out[x] = p;
      out[x + 1] = q;
      out[x + 2] = s;
      out[x + 3] = t;
    }
    for (; x < cols; ++x) out[x] = table[in[x]];
    return out;
  };
  // Where row y's derivatives go: gx, gy inside the band, the band's own rows at its borders.
  auto dx_row = [&](int y) -> int16_t* {
    if (y == y0 - 1) return band->border_dx.data();
    if (y == y1) return band->border_dx.data() + cols;
    return gx->ptr<int16_t>(y);
  };
  auto dy_row = [&](int y) -> int16_t* {
    if (y == y0 - 1) return band->border_dy.data();
    if (y == y1) return band->border_dy.data() + cols;
    return gy->ptr<int16_t>(y);
  };
  // The derivatives are computed row after row from `next`, three source rows at hand.
  int next = std::max(y0 - 1, 0);
  int slot[3] = {0, 1, 2};
  const uint8_t* src[3] = {source(next - 1, 0), source(next, 1), source(next + 1, 2)};
  auto gradients_to = [&](int y) {
    for (; next <= y && next < rows; ++next) {
      SobelRow(src[0], src[1], src[2], cols, dx_row(next), dy_row(next));
      const int freed = slot[0];
      slot[0] = slot[1];
      slot[1] = slot[2];
      slot[2] = freed;
      src[0] = src[1];
      src[1] = src[2];
      src[2] = source(next + 2, freed);
    }
  };
  auto magnitude = [&](int y, int32_t* out) {
    if (y < 0 || y >= rows) {
      std::fill(out, out + cols, 0);
      return;
    }
    gradients_to(y);
    cr::Magnitude(dx_row(y), dy_row(y), l2, out, cols);
  };
  int32_t* ring[3] = {band->magnitude.data() + 1, band->magnitude.data() + 1 + stride,
                      band->magnitude.data() + 1 + 2 * stride};
  for (int32_t* r : ring) r[-1] = r[cols] = 0;
  int32_t *above = ring[0], *here = ring[1], *below = ring[2];
  magnitude(y0 - 1, above);
  magnitude(y0, here);
  magnitude(y0 + 1, below);

  int32_t* stack = band->stack.data();
  size_t top = 0;
  for (int y = y0; y < y1; ++y) {
    if ((y - y0) % 32 == 0 && has_deadline && Clock::now() >= deadline) return false;
    uint8_t* row = map + stride * (y + 1) + 1;
    row[-1] = row[cols] = cr::kNotEdge;
    cr::SuppressRow(above, here, below, dx_row(y), dy_row(y), low, high, row, cols);
    cr::PushEdges(row, cols, map, stack, &top);
    int32_t* spare = above;
    above = here;
    here = below;
    below = spare;
    if (y + 2 <= y1) magnitude(y + 2, below);
  }
  return cr::Hysteresis(map, cols, stack, top, static_cast<int32_t>(stride * (y0 + 1)),
                        static_cast<int32_t>(stride * (y1 + 1)), deadline);
}

}  // namespace

int EdgeBandCount(int rows, int threads) {
  return std::clamp(std::min(4 * threads, rows / 64), 1, std::max(rows / 2, 1));
}

bool EdgeMapInBands(const cv::Mat& gray8, const uint8_t* table, double low, double high,
                    bool l2_gradient, WorkerPool* pool, EdgeBandsScratch* sc, cv::Mat* gx,
                    cv::Mat* gy, cv::Mat* edges, Clock::time_point deadline) {
  CV_Assert(gray8.type() == CV_8UC1 && gray8.rows >= 3 && gray8.cols >= 3);
  const int rows = gray8.rows, cols = gray8.cols;
  gx->create(rows, cols, CV_16SC1);
  gy->create(rows, cols, CV_16SC1);
  edges->create(rows, cols, CV_8UC1);
  int32_t ilow, ihigh;
  cr::Thresholds(low, high, l2_gradient, &ilow, &ihigh);
  const size_t stride = static_cast<size_t>(cols) + 2;
  const size_t map_size = stride * (static_cast<size_t>(rows) + 2);
  CV_Assert(map_size <= static_cast<size_t>(std::numeric_limits<int32_t>::max()));
  GrowTo(&sc->map, map_size);
  GrowTo(&sc->stack, static_cast<size_t>(rows) * cols);
  uint8_t* map = sc->map.data();
  std::memset(map, cr::kNotEdge, stride);
  std::memset(map + stride * (rows + 1), cr::kNotEdge, stride);

  // Bands of (nearly) equal height, each at least 2 rows (so that the rows where two bands
  // meet are two different rows for every pair).
  const int n = EdgeBandCount(rows, pool->threads());
  if (sc->bands.size() < static_cast<size_t>(n)) sc->bands.resize(n);
  for (int k = 0; k < n; ++k) {
    sc->bands[k].y0 = static_cast<int>(static_cast<int64_t>(rows) * k / n);
    sc->bands[k].y1 = static_cast<int>(static_cast<int64_t>(rows) * (k + 1) / n);
    sc->bands[k].interrupted = false;
  }
  pool->Run(n, [&](int k) {
    EdgeBandsScratch::Band* b = &sc->bands[k];
    b->interrupted = !BandEdges(gray8, table, ilow, ihigh, l2_gradient, deadline, b, map, gx, gy);
  });
  for (int k = 0; k < n; ++k)
    if (sc->bands[k].interrupted) return false;
  auto past = [&] { return deadline != Clock::time_point::max() && Clock::now() >= deadline; };
  if (past()) return false;

  // The hysteresis across bands: each band has grown its edges inside itself; the edges on
  // the rows where two bands meet grow on into the other band (and on from there).
  int32_t* stack = sc->stack.data();
  size_t top = 0;
  for (int k = 0; k + 1 < n; ++k) {
    const int y = sc->bands[k].y1;  // the next band's first row; y - 1 is this band's last
    cr::PushEdges(map + stride * y + 1, cols, map, stack, &top);
    cr::PushEdges(map + stride * (y + 1) + 1, cols, map, stack, &top);
  }
  if (!cr::Hysteresis(map, cols, stack, top, 0, static_cast<int32_t>(map_size), deadline))
    return false;

  // The final map on this thread: a copy of hundredths of a millisecond per megapixel, less
  // than what handing it to the pool's threads costs.
  for (int y = 0; y < rows; ++y) {
    if (y % 64 == 63 && past()) return false;
    cr::FinalRow(map + stride * (y + 1) + 1, edges->ptr<uint8_t>(y), cols);
  }
  return true;
}

}  // namespace svms
