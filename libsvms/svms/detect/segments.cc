#include "svms/detect/segments.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "svms/base/thread_scratch.h"
#include "svms/detect/canny.h"
#include "svms/detect/edge_bands.h"
#include "svms/detect/worker_pool.h"

namespace svms {
namespace {

// The first x' >= x with row[x'] != 0, or `cols`. Edge maps are mostly zero: whole 8-byte
// words are skipped (a byte-by-byte scan of a 1024 x 1024 map twice costs 0.8 ms).
int NextNonZero(const uint8_t* row, int x, int cols) {
  for (; x + 8 <= cols; x += 8) {
    uint64_t word;
    std::memcpy(&word, row + x, 8);
    if (word) break;
  }
  for (; x < cols && !row[x]; ++x) {
  }
  return x;
}

// EstimateReadNoise's sums: |4 I - (sum of the 4 neighbours)| at every 4th pixel of every
// 4th row (0.04 ms at 640 x 480 and 0.12-0.14 ms at 1024 x 1024 on one core, photographs), per
// grey-level bin (steps of 32), as histograms: the median without sorting or allocating. Integer
// counts, so the sums over bands of rows add up to the sums over the image exactly. Aligned to
// cache lines: the bands' tallies lie side by side, and a dark image's counts all fall in the first
// bin, next to the previous tally's counts.
struct alignas(64) ReadNoiseTally {
  static constexpr int kBins = 8, kLevels = 256;
  std::array<std::array<int, kLevels>, kBins> hist{};
  std::array<int64_t, kBins> level_sum{};
  std::array<int, kBins> count{};

  // The sampled rows (1, 5, 9, ...) in [y_begin, y_end).
  void Add(const cv::Mat& gray8, int y_begin, int y_end) {
    const int first = y_begin <= 1 ? 1 : y_begin + ((1 - y_begin) % 4 + 4) % 4;
    for (int y = first; y < y_end && y + 1 < gray8.rows; y += 4) {
      const uint8_t *up = gray8.ptr<uint8_t>(y - 1), *row = gray8.ptr<uint8_t>(y),
                    *down = gray8.ptr<uint8_t>(y + 1);
      for (int x = 1; x + 1 < gray8.cols; x += 4) {
        const int v = row[x];
        const int r = std::abs(4 * v - row[x - 1] - row[x + 1] - up[x] - down[x]);
        const int b = v >> 5;
        ++hist[b][std::min(r, kLevels - 1)];
        level_sum[b] += v;
        ++count[b];
      }
    }
  }
  void Add(const ReadNoiseTally& t) {
    for (int b = 0; b < kBins; ++b) {
      for (int l = 0; l < kLevels; ++l) hist[b][l] += t.hist[b][l];
      level_sum[b] += t.level_sum[b];
      count[b] += t.count[b];
    }
  }
  // The read noise from the darkest bin with enough samples (EstimateReadNoise).
  double Sigma() const {
    for (int b = 0; b < kBins; ++b) {
      if (count[b] < 500) continue;
      int seen = 0, median = 0;
      while (median < kLevels - 1 && (seen += hist[b][median]) < count[b] / 2) ++median;
      // White noise sigma gives the Laplacian a sigma of sqrt(20) sigma; 1.4826 x median |r|.
      const double sigma = 1.4826 * median / std::sqrt(20.0);
      const double shot = static_cast<double>(level_sum[b]) / count[b] / 64,
                   quantisation = 1.0 / 12;
      return std::sqrt(std::max(0.0, sigma * sigma - shot - quantisation));
    }
    return 0;
  }
};

// The pieces' starts (Segment::a) binned on a grid of square cells, for the searches of
// MergeCollinear and BridgeKinks: each looks at the starts near a piece's end. A window of x
// alone (every start within reach in x, at any y) holds far more starts than the window's
// cells on dense texture, where pieces number in the tens of thousands. Each cell holds its
// starts in (x, index) order, so a search can tell which of the starts it finds comes first.
struct StartGrid {
  // Sorted positions k: the pieces in (start x, index) order, order[k] the piece, xs[k], ys[k]
  // its start.
  std::vector<std::pair<double, int>> by_x;
  std::vector<int> order;
  std::vector<double> xs, ys;
  // The grid spans the finite starts: [x_min, x_max] x [y_min, y_max] in cols x rows cells of
  // `cell` px, stored row by row (cell r * cols + c). Cell c holds sorted positions
  // k[begin[c], begin[c + 1]) in increasing k, with copies of their starts in x[], y[] beside
  // them, so that the cells c0..c1 of a row are the one run [begin[c0], begin[c1 + 1]);
  // cell_of_piece[i] is piece i's cell.
  double x_min = 0, x_max = 0, y_min = 0, y_max = 0, cell = 1;
  int cols = 0, rows = 0;
  std::vector<int> begin, fill, k, cell_of_piece;
  std::vector<double> x, y;

  // Bins the starts of `v` in cells of at least `min_cell` px, larger where the starts spread
  // far (about 4 cells per piece at most). A start with a coordinate that is not a number is
  // sorted and binned as x = +infinity (a NaN would break the sort's ordering, and pass tests
  // written as "reject if greater"), so no finite window's x test passes it; a non-finite start
  // lands in a clamped cell; with no finite start the grid is one cell.
  void Build(const std::vector<Segment>& v, double min_cell) {
    const size_t n = v.size();
    by_x.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double x_key = std::isnan(v[i].a.x()) || std::isnan(v[i].a.y())
                               ? std::numeric_limits<double>::infinity()
                               : v[i].a.x();
      by_x[i] = {x_key, static_cast<int>(i)};
    }
    // Sorted as (start x, index) pairs: comparisons read contiguous memory instead of the
    // pieces, and ties in x keep index order.
    std::sort(by_x.begin(), by_x.end());
    order.resize(n);
    xs.resize(n);
    ys.resize(n);
    x_min = x_max = y_min = y_max = 0;
    bool any_finite = false;
    for (size_t q = 0; q < n; ++q) {
      order[q] = by_x[q].second;
      xs[q] = by_x[q].first;
      ys[q] = v[order[q]].a.y();
      if (!std::isfinite(xs[q]) || !std::isfinite(ys[q])) continue;
      x_min = any_finite ? std::min(x_min, xs[q]) : xs[q];
      x_max = any_finite ? std::max(x_max, xs[q]) : xs[q];
      y_min = any_finite ? std::min(y_min, ys[q]) : ys[q];
      y_max = any_finite ? std::max(y_max, ys[q]) : ys[q];
      any_finite = true;
    }
    if (!std::isfinite(x_max - x_min) || !std::isfinite(y_max - y_min))
      x_max = x_min, y_max = y_min;
    const double spread = std::max(x_max - x_min, y_max - y_min);
    cell = std::max(min_cell, spread / (2 * std::sqrt(static_cast<double>(n)) + 1));
    cols = n == 0 ? 0 : static_cast<int>((x_max - x_min) / cell) + 1;
    rows = n == 0 ? 0 : static_cast<int>((y_max - y_min) / cell) + 1;
    // Counting sort of the sorted positions by cell.
    const int cells = cols * rows;
    begin.assign(cells + 1, 0);
    for (size_t q = 0; q < n; ++q) ++begin[CellOf(xs[q], ys[q]) + 1];
    for (int c = 0; c < cells; ++c) begin[c + 1] += begin[c];
    fill.assign(begin.begin(), begin.end());
    k.resize(n);
    x.resize(n);
    y.resize(n);
    cell_of_piece.resize(n);
    for (size_t q = 0; q < n; ++q) {
      const int c = CellOf(xs[q], ys[q]);
      const int at = fill[c]++;
      k[at] = static_cast<int>(q);
      x[at] = xs[q];
      y[at] = ys[q];
      cell_of_piece[order[q]] = c;
    }
  }
  int cells() const { return cols * rows; }
  // The column (or row) of coordinate u: clamped to the grid (and 0 for a NaN) so that no value
  // is cast out of range.
  int Bin(double u, double u_min, int count) const {
    const double r = (u - u_min) / cell;
    return r >= 0 ? (r < count ? static_cast<int>(r) : count - 1) : 0;
  }
  int CellOf(double u, double w) const { return Bin(w, y_min, rows) * cols + Bin(u, x_min, cols); }
  // The cells a window [x0, x1] x [y0, y1] covers: rows *r0..*r1 (none where the window misses
  // the grid: *r1 < *r0), columns *c0..*c1.
  void Window(double x0, double x1, double y0, double y1, int* r0, int* r1, int* c0,
              int* c1) const {
    const bool overlaps = y0 <= y_max && y1 >= y_min && x0 <= x_max && x1 >= x_min;
    *r0 = Bin(y0, y_min, rows);
    *r1 = overlaps ? Bin(y1, y_min, rows) : *r0 - 1;
    *c0 = Bin(x0, x_min, cols);
    *c1 = Bin(x1, x_min, cols);
  }
};

// Buffers of FindSegments, kept per thread between calls so that a thread's detector
// allocates nothing once they have grown to its largest frame (the C API's promise).
struct SegmentScratch {
  cv::Mat stabilised, edges;
  CannyScratch canny;
  // The chains, end to end: chain c is points[chain_begin[c], chain_begin[c + 1]).
  std::vector<cv::Point> points, backward;
  std::vector<int> chain_begin;
  std::vector<uint8_t> rows_left;  // LinkChains: rows where its first pass left a pixel
  std::vector<std::pair<int, int>> pieces, merged;
  // With a worker pool: the longest chain of the frames this scratch's thread has linked. A
  // chain of n pixels splits into at most n - 1 pieces, and the fitting threads reserve their
  // `pieces` and `merged` to it before each frame: which thread fits which chain changes from
  // frame to frame, so buffers grown only by the chains a thread happened to get would still
  // grow (and allocate) on a later frame of the same scene.
  int longest_chain = 0;
  // MergeCollinear and BridgeKinks
  StartGrid grid;
  std::vector<char> gone;
  std::vector<Segment> kept;
  std::vector<Segment> wide_pieces;        // MergeCollinear: the pieces of joins across wide gaps
  std::vector<double> length;              // by piece
  std::vector<int> changed, changed_next;  // joins by cell
  std::vector<int> bridged;                // BridgeKinks: one piece's partners, sorted positions
  // With a worker pool: the edge map's bands, the read noise's sums by band, and the
  // segments of each part of the chains.
  EdgeBandsScratch bands;
  std::vector<ReadNoiseTally> tallies;
  std::vector<std::vector<Segment>> part_segments;  // by chunk of chains
};
SegmentScratch& Scratch() { return ThreadScratch<SegmentScratch>(); }

// 8-connected chains of edge pixels: each pixel belongs to one chain; chains start at end
// points (pixels with one neighbour) and then at whatever is left (closed loops). Chains of
// fewer than 4 pixels are left out. `edges` is consumed: a pixel is cleared once a chain has
// taken it. A separate "visited" map would cost a clear of every pixel and a second load per
// neighbour test: with one, linking takes 0.34 ms of the detector benchmark's 640 x 480 frame
// (4,300 chained pixels on a textured plate).
// False when `past` (checked every 32 rows) said the deadline had passed: the chains are then
// those of the rows before. `publish(c)` is called once chain c - 1 is complete, with chains
// 0 .. c - 1 final in sc->points and sc->chain_begin (for threads that fit them meanwhile,
// which needs both vectors' capacity reserved beforehand so that neither moves).
template <typename Past, typename Publish>
bool LinkChains(cv::Mat& edges, SegmentScratch* sc, const Past& past, const Publish& publish) {
  std::vector<cv::Point>& points = sc->points;
  points.clear();
  sc->chain_begin.assign(1, 0);
  static const int dx[8] = {1, 0, -1, 0, 1, -1, -1, 1}, dy[8] = {0, 1, 0, -1, 1, 1, -1, -1};
  const int cols = edges.cols, rows = edges.rows;
  uint8_t* const map = edges.ptr<uint8_t>(0);
  const size_t step = edges.step[0];
  auto is_edge = [&](int x, int y) {
    return static_cast<unsigned>(x) < static_cast<unsigned>(cols) &&
           static_cast<unsigned>(y) < static_cast<unsigned>(rows) && map[y * step + x];
  };
  auto neighbours = [&](int x, int y) {
    int n = 0;
    if (x > 0 && y > 0 && x + 1 < cols && y + 1 < rows) {
      // Inside the border (nearly every pixel): no bounds to check. The first pass asks this of
      // every edge pixel, which on texture is a large share of all pixels.
      const uint8_t* p = map + y * step + x;
      const uint8_t* above = p - step;
      const uint8_t* below = p + step;
      n = (above[-1] != 0) + (above[0] != 0) + (above[1] != 0) + (p[-1] != 0) + (p[1] != 0) +
          (below[-1] != 0) + (below[0] != 0) + (below[1] != 0);
      return n;
    }
    for (int k = 0; k < 8; ++k) n += is_edge(x + dx[k], y + dy[k]);
    return n;
  };
  // Walks from (x, y) while an untaken neighbour remains, appending to `chain`.
  auto walk = [&](int x, int y, std::vector<cv::Point>* chain) {
    for (;;) {
      int k = 0;
      if (x > 0 && y > 0 && x + 1 < cols && y + 1 < rows) {  // no bounds to check
        const uint8_t* p = map + y * step + x;
        for (; k < 8; ++k)
          if (p[static_cast<ptrdiff_t>(dy[k]) * static_cast<ptrdiff_t>(step) + dx[k]]) break;
      } else {
        for (; k < 8; ++k)
          if (is_edge(x + dx[k], y + dy[k])) break;
      }
      if (k == 8) return;
      x += dx[k];
      y += dy[k];
      map[y * step + x] = 0;
      chain->emplace_back(x, y);
    }
  };
  // A chain grows both ways from its first pixel: a start inside a closed curve (or at a
  // junction) must not leave the curve's other half behind in shreds. The forward half is
  // walked straight into `points`, the backward half into a buffer that is then put in front.
  auto follow = [&](int x, int y) {
    map[y * step + x] = 0;
    const size_t begin = points.size();
    points.emplace_back(x, y);
    walk(x, y, &points);
    sc->backward.clear();
    walk(x, y, &sc->backward);
    if (points.size() - begin + sc->backward.size() < 4) {
      points.resize(begin);
      return;
    }
    points.insert(points.begin() + static_cast<std::ptrdiff_t>(begin), sc->backward.rbegin(),
                  sc->backward.rend());
    sc->chain_begin.push_back(static_cast<int>(points.size()));
    publish(static_cast<int>(sc->chain_begin.size()) - 1);
  };
  // The second pass looks only at the rows where the first left a pixel (one with more than one
  // neighbour): the first pass only clears pixels and clears every start it follows, so no
  // other row holds one afterwards, and the map, mostly empty by then, is not scanned again.
  std::vector<uint8_t>& left = sc->rows_left;
  left.assign(static_cast<size_t>(rows), 0);
  for (int pass = 0; pass < 2; ++pass) {
    for (int y = 0; y < rows; ++y) {
      if (y % 32 == 31 && past()) return false;
      if (pass == 1 && !left[static_cast<size_t>(y)]) continue;
      const uint8_t* row = map + y * step;
      for (int x = 0; x < cols; ++x) {
        x = NextNonZero(row, x, cols);
        if (x == cols) break;
        if (pass == 0 && neighbours(x, y) > 1) {  // first the open chains' ends
          left[static_cast<size_t>(y)] = 1;
          continue;
        }
        follow(x, y);
      }
    }
  }
  return true;
}

// Douglas-Peucker split of chain[lo..hi] into pieces within `tol` of their chords.
void Split(const cv::Point* c, int lo, int hi, double tol, double rel,
           std::vector<std::pair<int, int>>* out) {
  const Eigen::Vector2d a(c[lo].x, c[lo].y), b(c[hi].x, c[hi].y);
  const Eigen::Vector2d d = b - a;
  const double len = d.norm();
  int worst = -1;
  double worst_dist = std::max(tol, rel * len);
  for (int i = lo + 1; i < hi; ++i) {
    const Eigen::Vector2d p(c[i].x, c[i].y);
    const double dist = len > 0 ? std::abs(d.x() * (p.y() - a.y()) - d.y() * (p.x() - a.x())) / len
                                : (p - a).norm();
    if (dist > worst_dist) {
      worst_dist = dist;
      worst = i;
    }
  }
  if (worst < 0) {
    out->emplace_back(lo, hi);
    return;
  }
  Split(c, lo, worst, tol, rel, out);
  Split(c, worst, hi, tol, rel, out);
}

// Largest distance of chain[lo..hi] from its total-least-squares line.
double MaxLineResidual(const cv::Point* c, int lo, int hi) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i = lo; i <= hi; ++i) mean += Eigen::Vector2d(c[i].x, c[i].y);
  mean /= hi - lo + 1;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (int i = lo; i <= hi; ++i) {
    const Eigen::Vector2d q = Eigen::Vector2d(c[i].x, c[i].y) - mean;
    cov += q * q.transpose();
  }
  const Eigen::Vector2d n =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>().computeDirect(cov).eigenvectors().col(0);
  double worst = 0;
  for (int i = lo; i <= hi; ++i)
    worst = std::max(worst, std::abs(n.dot(Eigen::Vector2d(c[i].x, c[i].y) - mean)));
  return worst;
}

// The merge half of split-and-merge: Douglas-Peucker cuts a digital line (a staircase whose
// pixels stray up to a pixel from the true edge) into short pieces wherever its chord happens
// to be off; neighbouring pieces whose union still fits one line within the tolerance are
// joined again.
void MergeAdjacent(const cv::Point* c, double tol, double rel,
                   std::vector<std::pair<int, int>>* pieces,
                   std::vector<std::pair<int, int>>* buffer) {
  std::vector<std::pair<int, int>>& out = *buffer;
  out.clear();
  for (const auto& p : *pieces) {
    if (!out.empty()) {
      const int lo = out.back().first, hi = p.second;
      const double len = std::hypot(c[hi].x - c[lo].x, c[hi].y - c[lo].y);
      if (MaxLineResidual(c, lo, hi) <= std::max(tol, rel * len)) {
        out.back().second = hi;
        continue;
      }
    }
    out.push_back(p);
  }
  pieces->swap(out);
}

// Step 3 for one chain: split where it stops being straight, a total-least-squares segment
// on each piece that is long enough, appended to *out in the chain's order. The chain may be
// rotated in place (a closed curve). `pieces`, `merged`: buffers.
void FitChain(cv::Point* chain, int chain_size, const SegmentOptions& o, const cv::Mat& gx,
              const cv::Mat& gy, std::vector<std::pair<int, int>>* pieces_buffer,
              std::vector<std::pair<int, int>>* merged, std::vector<Segment>* out) {
  std::vector<std::pair<int, int>>& pieces = *pieces_buffer;
  auto split = [&] {
    pieces.clear();
    Split(chain, 0, chain_size - 1, o.max_deviation, o.relative_deviation, &pieces);
    MergeAdjacent(chain, o.rejoin_deviation, o.relative_deviation, &pieces, merged);
  };
  split();
  // A closed curve's seam lies wherever the walk began, often just past a corner, which then
  // bends the first piece: start the curve again at its first corner and split once more.
  const cv::Point gap = chain[0] - chain[chain_size - 1];
  if (pieces.size() >= 2 && gap.dot(gap) <= 2) {
    std::rotate(chain, chain + pieces[0].second, chain + chain_size);
    split();
  }
  for (const auto& [lo, hi] : pieces) {
    if (hi - lo + 1 < o.min_length) continue;
    // Total least squares line through the piece's pixels, and its mean gradient.
    Eigen::Vector2d mean = Eigen::Vector2d::Zero(), g = Eigen::Vector2d::Zero();
    for (int i = lo; i <= hi; ++i) {
      mean += Eigen::Vector2d(chain[i].x, chain[i].y);
      g += Eigen::Vector2d(gx.at<int16_t>(chain[i]), gy.at<int16_t>(chain[i]));
    }
    const int n = hi - lo + 1;
    mean /= n;
    g /= n;
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (int i = lo; i <= hi; ++i) {
      const Eigen::Vector2d q = Eigen::Vector2d(chain[i].x, chain[i].y) - mean;
      cov += q * q.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es;
    es.computeDirect(cov);  // closed form for 2 x 2 (the iterative solver costs 3x more)
    const Eigen::Vector2d dir = es.eigenvectors().col(1);
    auto project = [&](const cv::Point& p) {
      return Eigen::Vector2d(mean + dir * dir.dot(Eigen::Vector2d(p.x, p.y) - mean));
    };
    Segment s;
    s.a = project(chain[lo]);
    s.b = project(chain[hi]);
    if (s.length() < o.min_length) continue;
    // Dark on the screen-right of a -> b: the gradient (dark to bright) points screen-left.
    const Eigen::Vector2d d = s.b - s.a, right(-d.y(), d.x());
    if (g.dot(right) > 0) std::swap(s.a, s.b);
    const Eigen::Vector2d u = (s.b - s.a).normalized();
    const Eigen::Vector2d nrm(-u.y(), u.x());
    s.line = Eigen::Vector3d(nrm.x(), nrm.y(), -nrm.dot(mean));
    s.contrast = g.norm() / 8;
    out->push_back(s);
  }
}

// EstimateReadNoise's estimate into *sigma, with its sums taken by bands of rows on the pool's
// threads. False when `past` said the deadline had passed (read before each band).
template <typename Past>
bool ReadNoiseInBands(const cv::Mat& gray8, WorkerPool* pool, const Past& past,
                      std::vector<ReadNoiseTally>* tallies, double* sigma) {
  *sigma = 0;
  if (gray8.rows < 8 || gray8.cols < 8 || gray8.type() != CV_8UC1) return true;
  const int n = EdgeBandCount(gray8.rows, pool->threads());
  if (tallies->size() < static_cast<size_t>(n)) tallies->resize(n);
  std::atomic<bool> stopped{false};
  pool->Run(n, [&](int k) {
    if (past()) {
      stopped = true;
      return;
    }
    ReadNoiseTally& t = (*tallies)[k];
    t = ReadNoiseTally();
    t.Add(gray8, static_cast<int>(static_cast<int64_t>(gray8.rows) * k / n),
          static_cast<int>(static_cast<int64_t>(gray8.rows) * (k + 1) / n));
  });
  if (stopped) return false;
  for (int k = 1; k < n; ++k) (*tallies)[0].Add((*tallies)[k]);
  *sigma = (*tallies)[0].Sigma();
  return true;
}

}  // namespace

Segment JoinSegments(const Segment& s, const Segment& t) {
  Segment m;
  m.a = s.a;
  m.b = t.b;
  const Eigen::Vector2d mid =
      (s.length() * 0.5 * (s.a + s.b) + t.length() * 0.5 * (t.a + t.b)) / (s.length() + t.length());
  const Eigen::Vector2d u = (m.b - m.a).normalized(), n(-u.y(), u.x());
  m.line = Eigen::Vector3d(n.x(), n.y(), -n.dot(mid));
  m.contrast = (s.contrast * s.length() + t.contrast * t.length()) / (s.length() + t.length());
  return m;
}

double EstimateReadNoise(const cv::Mat& gray8) {
  if (gray8.rows < 8 || gray8.cols < 8 || gray8.type() != CV_8UC1) return 0;
  ReadNoiseTally tally;
  tally.Add(gray8, 0, gray8.rows);
  return tally.Sigma();
}

std::vector<Segment> FindSegments(const cv::Mat& gray8, const SegmentOptions& o, cv::Mat* gx,
                                  cv::Mat* gy) {
  std::vector<Segment> out;
  FindSegments(gray8, o, gx, gy, &out);
  return out;
}

bool FindSegments(const cv::Mat& gray8, const SegmentOptions& o, cv::Mat* gx, cv::Mat* gy,
                  std::vector<Segment>* segments, std::chrono::steady_clock::time_point deadline,
                  WorkerPool* pool) {
  const bool has_deadline = deadline != std::chrono::steady_clock::time_point::max();
  auto past = [&] { return has_deadline && std::chrono::steady_clock::now() >= deadline; };
  SegmentScratch& sc = Scratch();
  std::vector<Segment>& out = *segments;
  out.clear();
  // Several threads split the edge map into bands of rows and the chains into parts; small
  // images are not worth it. Under a deadline the edge map is made by bands on this thread
  // alone (the same map): every part of it then reads the clock within 32 rows.
  const bool large = gray8.rows >= 128 && gray8.cols >= 16;
  const bool parallel = pool && pool->threads() > 1 && large;
  static WorkerPool this_thread_only(1);  // runs every part on the calling thread
  WorkerPool* band_pool = parallel ? pool : &this_thread_only;
  const bool banded = parallel || (has_deadline && large);
  // Edges are found on 16 sqrt(grey): shot noise makes the noise grow as the square root of
  // the signal, so on this scale it is about one level everywhere, and a marker in shadow
  // (white at 15, black at 3) shows a step of 35 instead of 12: one pair of thresholds serves
  // sunlit and shadowed markers alike. Later steps measure on the image itself.
  const cv::Mat* edge_input = &gray8;
  cv::Mat& stabilised = sc.stabilised;
  const uint8_t* __restrict table = nullptr;
  std::array<uint8_t, 256> noisy_lut;
  if (o.stabilise_variance) {
    static const std::array<uint8_t, 256> lut = [] {
      std::array<uint8_t, 256> t{};
      for (int v = 0; v < 256; ++v) t[v] = cv::saturate_cast<uint8_t>(16 * std::sqrt(v));
      return t;
    }();
    // With read noise: 16 (sqrt(grey + c) - sqrt(c)), c = 64 sigma^2 (see SegmentOptions).
    table = lut.data();
    double read_noise = 0;
    if (!banded) {
      read_noise = EstimateReadNoise(gray8);
    } else if (!ReadNoiseInBands(gray8, band_pool, past, &sc.tallies, &read_noise)) {
      return false;
    }
    if (read_noise > o.read_noise_gate) {
      const double c = 64 * read_noise * read_noise;
      for (int v = 0; v < 256; ++v)
        noisy_lut[v] = cv::saturate_cast<uint8_t>(16 * (std::sqrt(v + c) - std::sqrt(c)));
      table = noisy_lut.data();
    }
  }
  const double low = o.canny_low * 8 * o.noise_sigma, high = o.canny_high * 8 * o.noise_sigma;
  if (banded) {
    // The same derivatives and edges as below, computed by bands (edge_bands.h).
    if (!EdgeMapInBands(gray8, table, low, high, true, band_pool, &sc.bands, gx, gy, &sc.edges,
                        deadline))
      return false;
  } else {
    if (table) {
      // A plain loop, not cv::LUT: that one goes through parallel_for_, which allocates per
      // call.
      stabilised.create(gray8.size(), CV_8U);
      for (int y = 0; y < gray8.rows; ++y) {
        if (y % 64 == 63 && past()) return false;
        const uint8_t* __restrict in = gray8.ptr<uint8_t>(y);
        uint8_t* __restrict o8 = stabilised.ptr<uint8_t>(y);
        int x = 0;
        // Four loads before four stores: as fast as cv::LUT on one core (0.29 ms at 1024x1024).
        for (; x + 4 <= gray8.cols; x += 4) {
          const uint8_t a = table[in[x]], b = table[in[x + 1]], c = table[in[x + 2]],
                        d = table[in[x + 3]];
          o8[x] = a;
          o8[x + 1] = b;
          o8[x + 2] = c;
          o8[x + 3] = d;
        }
        for (; x < gray8.cols; ++x) o8[x] = table[in[x]];
      }
      edge_input = &stabilised;
    }
    // Both 3x3 Sobel derivatives in one pass (the same values as two cv::Sobel calls), the one
    // part of the edge map that does not read the clock (0.4 ms at 1024 x 1024 on one core).
    if (past()) return false;
    cv::spatialGradient(*edge_input, *gx, *gy, 3);
    // OpenCV's cv::Canny, reproduced without its per-call allocations (canny.h). Sobel is 8x
    // the slope.
    if (!CannyFromDerivatives(*gx, *gy, low, high, true, &sc.canny, &sc.edges, deadline))
      return false;
  }
  if (past()) return false;
  if (parallel) {
    // Linking and fitting overlap: one thread links the chains and publishes each as it is
    // complete, while the others (and the linker, once done) fit them in chunks of
    // kChunkChains, each chunk into its own list; the lists put end to end are the serial
    // order. The linking is serial (which chain takes a pixel depends on the order of the
    // walks), and on textured frames it costs about half as much as the fits.
    constexpr int kChunkChains = 16;
    // No chain is shorter than 4 pixels and no pixel is in two: the vectors the fitting threads
    // read while the linker appends are reserved to what the edge map can fill, so they do not
    // move.
    const int edge_pixels = cv::countNonZero(sc.edges);
    sc.points.reserve(static_cast<size_t>(edge_pixels));
    sc.chain_begin.reserve(static_cast<size_t>(edge_pixels) / 4 + 2);
    const size_t max_chunks = static_cast<size_t>(edge_pixels) / 4 / kChunkChains + 1;
    if (sc.part_segments.size() < max_chunks) sc.part_segments.resize(max_chunks);
    cv::Point* const points = sc.points.data();  // FitChain may turn a closed chain in place
    const int* const chain_begin = sc.chain_begin.data();
    // The linker writes `published` once per chain: the fitters' claim counter and flags sit on
    // cache lines of their own.
    alignas(64) std::atomic<int> published{0};
    alignas(64) std::atomic<int> next_chunk{0};
    alignas(64) std::atomic<bool> linked{false};
    std::atomic<bool> stopped{false};
    const size_t longest_before = static_cast<size_t>(sc.longest_chain);
    pool->Run(pool->threads(), [&](int part) {
      if (part == 0) {
        // `linked` is set however the linking ends (an exception included: the pool rethrows
        // it once every part has returned), so that no fitter waits for ever.
        struct Done {
          std::atomic<bool>* stopped;
          std::atomic<bool>* linked;
          bool returned = false;
          ~Done() {
            if (!returned) stopped->store(true);
            linked->store(true, std::memory_order_release);
          }
        } done{&stopped, &linked};
        const bool complete = LinkChains(sc.edges, &sc, past, [&](int chains) {
          published.store(chains, std::memory_order_release);
        });
        const int linked_chains = static_cast<int>(sc.chain_begin.size()) - 1;
        published.store(linked_chains, std::memory_order_release);
        if (!complete) stopped = true;
        done.returned = true;
        // While the others fit: the next frame's reservation (only the linker writes it here).
        for (int c = 0; c < linked_chains; ++c)
          sc.longest_chain = std::max(sc.longest_chain, chain_begin[c + 1] - chain_begin[c]);
      }
      // This thread's own buffers for the pieces (the chains are the caller's), reserved to the
      // longest chain of the frames before (see SegmentScratch::longest_chain).
      SegmentScratch& mine = Scratch();
      if (mine.pieces.capacity() < longest_before) mine.pieces.reserve(longest_before);
      if (mine.merged.capacity() < longest_before) mine.merged.reserve(longest_before);
      for (int spins = 0;;) {
        if (stopped.load(std::memory_order_relaxed)) return;
        const int k = next_chunk.fetch_add(1, std::memory_order_relaxed);
        const int lo = k * kChunkChains;
        int hi = lo + kChunkChains;
        // Wait for the chunk's chains.
        for (;;) {
          const bool done = linked.load(std::memory_order_acquire);
          const int ready = published.load(std::memory_order_acquire);
          if (ready >= hi) break;
          if (done) {
            hi = ready;
            break;
          }
          // Yielding now and then, so that a machine with more threads than cores lets the
          // linker run.
          if (++spins % 64 == 0) std::this_thread::yield();
          CpuRelax();
        }
        if (lo >= hi || stopped.load(std::memory_order_relaxed)) return;
        std::vector<Segment>& chunk = sc.part_segments[static_cast<size_t>(k)];
        chunk.clear();
        for (int c = lo; c < hi; ++c) {
          if (c % 64 == 63 && past()) {
            stopped = true;
            return;
          }
          FitChain(points + chain_begin[c], chain_begin[c + 1] - chain_begin[c], o, *gx, *gy,
                   &mine.pieces, &mine.merged, &chunk);
        }
      }
    });
    if (stopped) return false;
    const int chains = static_cast<int>(sc.chain_begin.size()) - 1;
    // The reservation above is what kept the fitters' pointers valid.
    assert(sc.points.data() == points && sc.chain_begin.data() == chain_begin);
    for (int k = 0; k * kChunkChains < chains; ++k)
      out.insert(out.end(), sc.part_segments[static_cast<size_t>(k)].begin(),
                 sc.part_segments[static_cast<size_t>(k)].end());
  } else {
    if (!LinkChains(sc.edges, &sc, past, [](int) {})) return false;
    const int chains = static_cast<int>(sc.chain_begin.size()) - 1;
    for (int c = 0; c < chains; ++c) {
      if (c % 64 == 63 && past()) return false;
      FitChain(sc.points.data() + sc.chain_begin[c], sc.chain_begin[c + 1] - sc.chain_begin[c], o,
               *gx, *gy, &sc.pieces, &sc.merged, &out);
    }
  }
  if (past() || !MergeCollinear(o, &out, deadline) || past()) return false;
  BridgeKinks(o, &out);
  return true;
}

bool MergeCollinear(const SegmentOptions& o, std::vector<Segment>* segs,
                    std::chrono::steady_clock::time_point deadline) {
  const bool has_deadline = deadline != std::chrono::steady_clock::time_point::max();
  SegmentScratch& sc = Scratch();
  const double cos_max = std::cos(o.merge_angle_deg * M_PI / 180);
  const double both_long = 4 * o.merge_offset_px / std::tan(o.merge_angle_deg * M_PI / 180);
  auto dist_to_line = [](const Segment& s, const Eigen::Vector2d& p) {
    return std::abs(s.line.head<2>().dot(p) + s.line.z());
  };
  const double offset2 = o.merge_offset_px * o.merge_offset_px;
  // Sweeps over the pieces in index order, each piece joining the first start in x order that
  // passes every test, and joining on from its new end at once; sweeps repeat until one joins
  // nothing (a join lengthens a piece and moves its line, so a pair refused earlier may pass
  // later).
  //
  // A join keeps the first piece's start (JoinSegments) and a joined piece is only marked gone,
  // so the starts' grid (StartGrid, cells of at least kCell px) is built once for all sweeps.
  // Of the starts in a piece's window that pass every test the first in x order is joined, as a
  // scan of the whole x window would: the grid changes the cost, not the result.
  //
  // After the first sweep a piece that has not changed since its last search (it is unchanged
  // until it joins in its own turn) is searched again only where its window's cells hold the
  // start of a piece that has itself joined since then (counted per cell of the joining piece's
  // start in `changed`: the joins of the sweep before and of this one so far): against pieces
  // that have not changed it would fail as it failed before, and a piece marked gone only
  // removes a candidate. Once it has joined in this turn, its end and line are new and it
  // searches its whole window. The repeated sweeps then cost little; the result is that of full
  // sweeps (segments_test.cc checks it against full sweeps of the whole x window, to the bit).
  //
  // The sweeps run on one thread, with or without a worker pool: a join changes what the pieces
  // after it find, so threads could only search ahead and search again where a join came into a
  // piece's window; on dense texture, where the merge costs most, the searches made again and
  // those made for pieces joined away before their turn cost what the threads would save.
  constexpr double kCell = 8;
  std::vector<Segment>& v = *segs;
  const size_t n = v.size();
  StartGrid& g = sc.grid;
  g.Build(v, kCell);
  const std::vector<int>& order = g.order;
  std::vector<double>& len = sc.length;
  len.resize(n);
  for (size_t i = 0; i < n; ++i) len[i] = v[i].length();
  const int cells = g.cells();
  std::vector<char>& gone = sc.gone;
  gone.assign(n, 0);
  // Joins by the cell of the joining piece's start: since the sweep before began (`changed`),
  // and since this sweep began (`changed_next`, the next sweep's `changed`).
  std::vector<int>&changed = sc.changed, &changed_next = sc.changed_next;
  changed.assign(cells, 0);
  std::vector<Segment>& wide_pieces = sc.wide_pieces;
  wide_pieces.clear();
  bool merged = true;
  for (bool first = true; merged; first = false) {
    merged = false;
    if (!first) changed.swap(changed_next);
    changed_next.assign(cells, 0);
    for (size_t i = 0; i < n; ++i) {
      if (i % 256 == 255 && has_deadline && std::chrono::steady_clock::now() >= deadline)
        return false;
      if (gone[i]) continue;
      bool moved = false;  // piece i has joined in this turn
      for (bool joined = true; joined;) {
        joined = false;
        const Segment& s = v[i];
        const Eigen::Vector2d di = (s.b - s.a) / len[i];
        const double max_gap_i = std::max(o.merge_gap_px, o.merge_gap_fraction * len[i]);
        const double reach = max_gap_i + 1;
        const double y_reach = reach + 2 * o.merge_offset_px;
        // Starts with x in [b.x - reach, b.x + reach] and y within y_reach of b.y.
        const double x_begin = s.b.x() - reach, x_end = s.b.x() + reach, y = s.b.y();
        int r_lo, r_hi, c_lo, c_hi;
        g.Window(x_begin, x_end, y - y_reach, y + y_reach, &r_lo, &r_hi, &c_lo, &c_hi);
        if (!first && !moved) {
          bool any_changed = false;
          for (int r = r_lo; r <= r_hi && !any_changed; ++r)
            for (int c = r * g.cols + c_lo; c <= r * g.cols + c_hi && !any_changed; ++c)
              any_changed = changed[c] > 0;
          if (!any_changed) break;
        }
        // The piece whose start passes every test, first in x order: sorted position and index.
        int best_k = std::numeric_limits<int>::max(), best = -1;
        for (int r = r_lo; r <= r_hi; ++r) {
          // A row's cells c_lo..c_hi hold one run of the grid's entries (cells are stored row
          // by row): one loop over it, not one per cell (most cells of a long piece's window
          // are empty).
          for (int e = g.begin[r * g.cols + c_lo]; e < g.begin[r * g.cols + c_hi + 1]; ++e) {
            const int k = g.k[e];
            if (k >= best_k) continue;  // not earlier in x order than the best so far
            if (g.x[e] < x_begin || g.x[e] > x_end) continue;
            // The start must be near in y as well (the gap along the piece is below reach
            // and the offset across it below two merge offsets).
            if (std::abs(g.y[e] - y) > y_reach) continue;
            // The gap along the piece, from the start's copy in the grid (the test below with
            // this piece's length for the shorter one's: a bound that needs no other piece).
            const double gap = (g.x[e] - s.b.x()) * di.x() + (g.y[e] - y) * di.y();
            if (gap > max_gap_i || gap < -o.merge_gap_px) continue;
            const int j = order[k];
            if (j == static_cast<int>(i) || gone[j]) continue;
            const Segment& t = v[j];
            const double shorter = std::min(len[i], len[j]);
            if (gap > std::max(o.merge_gap_px, o.merge_gap_fraction * shorter) ||
                gap < -o.merge_gap_px)
              continue;
            // A short piece's direction is uncertain: allow it the angle at which its own
            // length moves its far end by merge_offset_px, cos(atan(offset / shorter)) =
            // shorter / sqrt(shorter^2 + offset^2), compared squared (this runs for every pair).
            const double cos_turn = di.dot(t.b - t.a) / len[j];
            if (cos_turn < cos_max &&
                (cos_turn <= 0 ||
                 cos_turn * cos_turn * (shorter * shorter + offset2) < shorter * shorter))
              continue;
            // The shorter piece's ends must lie on the longer piece's line (the better-measured
            // of the two); the longer piece's ends on the shorter's line only when both are
            // long.
            const Segment& longer = len[i] >= len[j] ? s : t;
            const Segment& other = len[i] >= len[j] ? t : s;
            if (dist_to_line(longer, other.a) > o.merge_offset_px ||
                dist_to_line(longer, other.b) > o.merge_offset_px)
              continue;
            if (shorter > both_long && (dist_to_line(other, longer.a) > o.merge_offset_px ||
                                        dist_to_line(other, longer.b) > o.merge_offset_px))
              continue;
            best_k = k;
            best = j;
          }
        }
        if (best >= 0) {
          // Across a gap wider than merge_gap_px the pieces are kept too: a marker's side and a
          // background edge that lines up with it beyond its stripe and ring (a circuit board's
          // trace, a panel's edge) are joined, and the side alone is what the quad search needs.
          if ((v[best].a - s.b).dot(di) > o.merge_gap_px) {
            wide_pieces.push_back(s);
            wide_pieces.push_back(v[best]);
          }
          v[i] = JoinSegments(s, v[best]);
          len[i] = v[i].length();
          gone[best] = 1;
          ++changed[g.cell_of_piece[i]];
          ++changed_next[g.cell_of_piece[i]];
          merged = joined = moved = true;
        }
      }
    }
  }
  std::vector<Segment>& kept = sc.kept;
  kept.clear();
  for (size_t i = 0; i < n; ++i)
    if (!gone[i]) kept.push_back(v[i]);
  kept.insert(kept.end(), wide_pieces.begin(), wide_pieces.end());
  segs->swap(kept);
  return true;
}

void BridgeKinks(const SegmentOptions& o, std::vector<Segment>* segs) {
  if (o.bridge_max_turn_deg <= 0) return;
  SegmentScratch& sc = Scratch();
  std::vector<Segment>& v = *segs;
  const size_t n = v.size();
  const double gap = o.bridge_gap_px;
  // The starts within `gap` of a piece's end, from the cells of the grid, put in (x, index)
  // order.
  StartGrid& g = sc.grid;
  g.Build(v, std::max(2 * gap, 1.0));
  // The rows are widened by a hair: a start whose distance rounds to `gap` may lie a rounding
  // step beyond it in y. The columns need none: x is tested against the same
  // b.x -+ gap the columns come from.
  const double cos_max = std::cos(o.bridge_max_turn_deg * M_PI / 180);
  std::vector<int>& partners = sc.bridged;
  for (size_t i = 0; i < n; ++i) {
    const Segment s = v[i];  // a copy: v grows below
    const Eigen::Vector2d di = (s.b - s.a) / s.length();
    const double x_begin = s.b.x() - gap, x_end = s.b.x() + gap;
    int r0, r1, c0, c1;
    const double y_slack = 1e-9 * (1 + gap + std::abs(s.b.y()));
    g.Window(x_begin, x_end, s.b.y() - gap - y_slack, s.b.y() + gap + y_slack, &r0, &r1, &c0, &c1);
    partners.clear();
    for (int r = r0; r <= r1; ++r) {
      for (int e = g.begin[r * g.cols + c0]; e < g.begin[r * g.cols + c1 + 1]; ++e) {
        if (g.x[e] < x_begin || g.x[e] > x_end) continue;
        const int j = g.order[g.k[e]];
        const Segment& t = v[j];
        if (j == static_cast<int>(i) || (t.a - s.b).norm() > gap) continue;
        const Eigen::Vector2d dj = (t.b - t.a) / t.length();
        // A bend either way; corners (>= bridge_max_turn_deg) are left to the quad search.
        if (di.dot(dj) < cos_max) continue;
        partners.push_back(g.k[e]);
      }
    }
    std::sort(partners.begin(), partners.end());
    for (const int k : partners) v.push_back(JoinSegments(s, v[g.order[k]]));
  }
}

}  // namespace svms
