// Detector steps 1-4 on synthetic images and segments with known answers.
#include "svms/detect/segments.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/detect/quads.h"
#include "svms/detect/worker_pool.h"

namespace svms {
namespace {

// A square of side `side` px and grey level `grey` centred at (cx, cy), turned by `deg`,
// painted by exact area coverage (16 x 16 samples per pixel, pixel centres at integers, as in
// docs/conventions.md). Returns its corners clockwise on screen.
std::array<Eigen::Vector2d, 4> DrawSquare(cv::Mat& img, double cx, double cy, double side,
                                          double deg, uint8_t grey = 20) {
  const double a = deg * M_PI / 180, h = side / 2;
  const Eigen::Vector2d u(std::cos(a), std::sin(a)), v(-std::sin(a), std::cos(a)), c(cx, cy);
  const std::array<Eigen::Vector2d, 4> corners = {c - h * u - h * v, c + h * u - h * v,
                                                  c + h * u + h * v, c - h * u + h * v};
  const int x0 = std::max(0, static_cast<int>(cx - side)),
            x1 = std::min(img.cols, static_cast<int>(cx + side) + 1);
  const int y0 = std::max(0, static_cast<int>(cy - side)),
            y1 = std::min(img.rows, static_cast<int>(cy + side) + 1);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      int inside = 0;
      for (int sy = 0; sy < 16; ++sy)
        for (int sx = 0; sx < 16; ++sx) {
          const Eigen::Vector2d p(x - 0.5 + (sx + 0.5) / 16, y - 0.5 + (sy + 0.5) / 16);
          const Eigen::Vector2d q = p - c;
          inside += std::abs(q.dot(u)) <= h && std::abs(q.dot(v)) <= h;
        }
      uint8_t& px = img.at<uint8_t>(y, x);
      px = cv::saturate_cast<uint8_t>((inside * grey + (256 - inside) * px) / 256.0);
    }
  return corners;
}

double DistToLine(const Eigen::Vector3d& l, const Eigen::Vector2d& p) {
  return std::abs(l.head<2>().dot(p) + l.z());
}

// Every side of a lone square (a closed edge curve, no end points) is found as one or two
// segments covering most of it, with the dark side on its right, within a pixel or so (edge
// pixels are whole pixels; step 8 refines), and the quad is found, at every rotation: a chain
// started inside a closed curve must not leave it in shreds.
TEST(Segments, EachSideOfASquareIsFoundWholeAtEveryRotation) {
  for (double deg = 0; deg < 90; deg += 3.7) {
    for (double side : {24.0, 60.0}) {
      cv::Mat img(120, 120, CV_8U, cv::Scalar(200));
      const auto c = DrawSquare(img, 60.3, 59.6, side, deg);
      cv::Mat gx, gy;
      const std::vector<Segment> segs = FindSegments(img, SegmentOptions{}, &gx, &gy);
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d a = c[k], b = c[(k + 1) % 4];
        int matches = 0;
        double covered = 0;
        for (const Segment& s : segs) {
          // Walking a -> b clockwise on screen has the dark square on the right.
          if (DistToLine(s.line, 0.5 * (a + b)) > 1.0 || (s.b - s.a).dot(b - a) <= 0) continue;
          ++matches;
          covered += s.length();
          EXPECT_GT(s.contrast, 20);
        }
        EXPECT_GE(matches, 1) << "deg " << deg << " side " << side << " side index " << k;
        EXPECT_LE(matches, 2) << "deg " << deg << " side " << side << " side index " << k;
        EXPECT_GT(covered, 0.7 * side) << "deg " << deg << " side " << side << " k " << k;
      }
      double best = 1e9;
      for (const Quad& q : FindQuads(segs, QuadOptions{}, img.cols, img.rows))
        for (int r = 0; r < 4; ++r) {
          double worst = 0;
          for (int k = 0; k < 4; ++k)
            worst = std::max(worst, (q.corners[(k + r) % 4] - c[k]).norm());
          best = std::min(best, worst);
        }
      EXPECT_LT(best, 1.5) << "deg " << deg << " side " << side;
    }
  }
}

// A segment from a to b with its line and a contrast of 50.
Segment MakeSegment(Eigen::Vector2d a, Eigen::Vector2d b) {
  Segment s;
  s.a = a;
  s.b = b;
  const Eigen::Vector2d u = (b - a).normalized(), n(-u.y(), u.x());
  s.line = Eigen::Vector3d(n.x(), n.y(), -n.dot(a));
  s.contrast = 50;
  return s;
}

TEST(Segments, MergeJoinsPiecesOfOneEdgeButNotACorner) {
  auto make = MakeSegment;
  // A long piece and a short one whose direction is 9 degrees off (a one-pixel bump near a
  // corner): one edge.
  std::vector<Segment> v = {make({0, 0}, {22, 1.2}), make({22.5, 1.6}, {30.5, 0.8})};
  MergeCollinear(SegmentOptions{}, &v);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_NEAR(v[0].a.x(), 0, 1e-9);
  EXPECT_NEAR(v[0].b.x(), 30.5, 1e-9);
  // A real corner (a turn of 25 degrees) and a parallel edge 3 px away stay apart.
  std::vector<Segment> w = {make({0, 0}, {20, 0}), make({21, 0}, {30, 4.7}), make({0, 3}, {20, 3})};
  MergeCollinear(SegmentOptions{}, &w);
  EXPECT_EQ(w.size(), 3u);
}

// The oracle for MergeCollinear's grid: the same tests on every start within reach in x, at
// any y, first in x order (the merge without its grid),
// joined with the merge's own JoinSegments (the joined line decides later joins).
// Returns how many pieces of joins across wide gaps it appended (they are not joins).
size_t MergeCollinearByXWindow(const SegmentOptions& o, std::vector<Segment>* segs) {
  const double cos_max = std::cos(o.merge_angle_deg * M_PI / 180);
  const double both_long = 4 * o.merge_offset_px / std::tan(o.merge_angle_deg * M_PI / 180);
  const double offset2 = o.merge_offset_px * o.merge_offset_px;
  auto dist = [](const Segment& s, const Eigen::Vector2d& p) {
    return std::abs(s.line.head<2>().dot(p) + s.line.z());
  };
  std::vector<Segment> wide;  // the pieces of joins across gaps over merge_gap_px, kept too
  for (bool merged = true; merged;) {
    merged = false;
    std::vector<Segment>& v = *segs;
    std::vector<int> order(v.size());
    std::vector<double> len(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      order[i] = static_cast<int>(i);
      len[i] = v[i].length();
    }
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      return std::make_pair(v[a].a.x(), a) < std::make_pair(v[b].a.x(), b);
    });
    std::vector<char> gone(v.size(), 0);
    for (size_t i = 0; i < v.size(); ++i) {
      if (gone[i]) continue;
      for (bool joined = true; joined;) {
        joined = false;
        const Segment& s = v[i];
        const Eigen::Vector2d di = (s.b - s.a) / len[i];
        const double reach = std::max(o.merge_gap_px, o.merge_gap_fraction * len[i]) + 1;
        for (size_t k = 0; k < order.size(); ++k) {
          const int j = order[k];
          const Segment& t = v[j];
          if (t.a.x() < s.b.x() - reach || t.a.x() > s.b.x() + reach ||
              std::abs(t.a.y() - s.b.y()) > reach + 2 * o.merge_offset_px)
            continue;
          if (j == static_cast<int>(i) || gone[j]) continue;
          const double shorter = std::min(len[i], len[j]);
          const double gap = (t.a - s.b).dot(di);
          if (gap > std::max(o.merge_gap_px, o.merge_gap_fraction * shorter) ||
              gap < -o.merge_gap_px)
            continue;
          const double c = di.dot(t.b - t.a) / len[j];
          if (c < cos_max && (c <= 0 || c * c * (shorter * shorter + offset2) < shorter * shorter))
            continue;
          const Segment& longer = len[i] >= len[j] ? s : t;
          const Segment& other = len[i] >= len[j] ? t : s;
          if (dist(longer, other.a) > o.merge_offset_px ||
              dist(longer, other.b) > o.merge_offset_px)
            continue;
          if (shorter > both_long && (dist(other, longer.a) > o.merge_offset_px ||
                                      dist(other, longer.b) > o.merge_offset_px))
            continue;
          if (gap > o.merge_gap_px) {
            wide.push_back(s);
            wide.push_back(t);
          }
          v[i] = JoinSegments(s, t);
          len[i] = v[i].length();
          gone[j] = 1;
          merged = joined = true;
          break;
        }
      }
    }
    if (merged) {
      std::vector<Segment> kept;
      for (size_t i = 0; i < v.size(); ++i)
        if (!gone[i]) kept.push_back(v[i]);
      segs->swap(kept);
    }
  }
  segs->insert(segs->end(), wide.begin(), wide.end());
  return wide.size();
}

// Appends `count` short pieces (4-12 px, any direction) starting where `pos` draws: what
// foliage gives.
template <typename Rng>
void AddClutter(int count, std::uniform_real_distribution<double>& pos, Rng& rng,
                std::vector<Segment>* v) {
  std::uniform_real_distribution<double> unit(0, 1);
  for (int c = 0; c < count; ++c) {
    const Eigen::Vector2d a = DrawVector2(pos, rng);
    const double ang = unit(rng) * 2 * M_PI;
    v->push_back(
        MakeSegment(a, a + (4 + 8 * unit(rng)) * Eigen::Vector2d(std::cos(ang), std::sin(ang))));
  }
}

// Random edges cut into jittered pieces with gaps, crossing one another, plus short clutter
// pieces (what foliage gives): the merge joins exactly the pieces the x-window oracle joins, in
// the same order, to the bit.
// `trials` random sets of pieces (25 long edges cut into pieces 3-33 px long with gaps of up to
// `max_gap` px, `clutter` short pieces), each starting in [0, extent)^2: the merge must give what
// full sweeps scanning the whole x window give (MergeCollinearByXWindow), to the bit. Returns
// the number of joins; *cell_px gets the largest grid cell the merge used over the trials (its
// rule, restated: 8 px, or the starts' spread over 2 sqrt(n) + 1 where that is more).
size_t CompareMergeWithXWindowScan(double extent, int clutter, int trials, uint32_t seed,
                                   double* cell_px, double max_gap = 3) {
  *cell_px = 0;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent), unit(0, 1), jitter(-0.6, 0.6);
  size_t joins = 0;
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<Segment> v;
    for (int e = 0; e < 25; ++e) {  // long edges in pieces
      const Eigen::Vector2d a = DrawVector2(pos, rng);
      const double ang = unit(rng) * 2 * M_PI;
      const Eigen::Vector2d u(std::cos(ang), std::sin(ang)), n(-u.y(), u.x());
      double t = 0;
      const double total = 20 + 200 * unit(rng);
      while (t < total) {
        const double piece = 3 + 30 * unit(rng);
        const Eigen::Vector2d across = DrawVector2(jitter, rng);  // the start's, the end's
        v.push_back(MakeSegment(a + t * u + across.x() * n, a + (t + piece) * u + across.y() * n));
        t += piece + max_gap * unit(rng);
      }
    }
    AddClutter(clutter, pos, rng, &v);
    std::shuffle(v.begin(), v.end(), rng);
    const size_t pieces = v.size();
    Eigen::Vector2d lo = v[0].a, hi = v[0].a;
    for (const Segment& s : v) lo = lo.cwiseMin(s.a), hi = hi.cwiseMax(s.a);
    *cell_px = std::max(*cell_px,
                        std::max(8.0, (hi - lo).maxCoeff() / (2 * std::sqrt(double(pieces)) + 1)));
    std::vector<Segment> expected = v;
    const size_t wide = MergeCollinearByXWindow(SegmentOptions{}, &expected);
    EXPECT_TRUE(MergeCollinear(SegmentOptions{}, &v));
    joins += pieces + wide - v.size();
    EXPECT_EQ(v.size(), expected.size()) << "extent " << extent << " trial " << trial;
    if (v.size() != expected.size()) return joins;
    for (size_t i = 0; i < v.size(); ++i) {
      EXPECT_EQ(v[i].a, expected[i].a) << "extent " << extent << " trial " << trial << " " << i;
      EXPECT_EQ(v[i].b, expected[i].b) << "extent " << extent << " trial " << trial << " " << i;
      EXPECT_EQ(v[i].line, expected[i].line) << "extent " << extent << " trial " << trial;
    }
  }
  return joins;
}

TEST(Segments, MergeFindsWhatAScanOfTheWholeXWindowFinds) {
  // Every size of the grid's cells: 8 px (about 2,700 pieces starting within about 740 px),
  // 9-16 px (about 470 pieces there), over 100 px (starts spread over 5000 px).
  double dense_cell, medium_cell, sparse_cell;
  const size_t dense = CompareMergeWithXWindowScan(300, 2500, 20, 11, &dense_cell);
  const size_t medium = CompareMergeWithXWindowScan(300, 300, 30, 12, &medium_cell);
  const size_t sparse = CompareMergeWithXWindowScan(5000, 300, 20, 13, &sparse_cell);
  EXPECT_EQ(dense_cell, 8);
  EXPECT_GT(medium_cell, 8);
  EXPECT_LT(medium_cell, 20);
  EXPECT_GT(sparse_cell, 50);
  // The trials join pieces, or they would test nothing.
  EXPECT_GT(dense, 20u * 100);
  EXPECT_GT(medium, 30u * 100);
  EXPECT_GT(sparse, 20u * 100);
  // Gaps of up to 6 px straddle the gap test (3 px, or half the shorter piece): a pair refused
  // in one sweep passes once a join has lengthened its shorter piece, often in the same sweep
  // after the first piece's turn. After the first sweep the merge searches an unchanged piece
  // again only where a piece starting in its window has joined since: this checks, with the
  // chain-order test below, that it misses none.
  double gappy_cell;
  const size_t gappy = CompareMergeWithXWindowScan(300, 0, 100, 26, &gappy_cell, 6);
  EXPECT_GT(gappy, 100u * 50);
  // A piece whose start has a coordinate that is not a number is never joined to (no finite
  // window's x test passes it), and nothing crashes, whichever of the two comes first.
  for (int nan_first = 0; nan_first < 4; ++nan_first) {
    std::vector<Segment> odd = {MakeSegment({0, 0}, {10, 0}), MakeSegment({10.5, 0}, {20, 0})};
    odd[1].a =
        nan_first < 2 ? Eigen::Vector2d(std::nan(""), 0) : Eigen::Vector2d(10.5, std::nan(""));
    if (nan_first % 2) std::swap(odd[0], odd[1]);
    EXPECT_TRUE(MergeCollinear(SegmentOptions{}, &odd));
    EXPECT_EQ(odd.size(), 2u) << nan_first;
    std::vector<Segment> bridged = odd;
    BridgeKinks(SegmentOptions{}, &bridged);
    EXPECT_EQ(bridged.size(), 2u) << nan_first;
  }
}

// A piece that joins in a later sweep searches on from its new end there and then: pieces in
// chain order along one line: the first sweep joins the second and third pieces, the second
// sweep joins the first piece to them, and only from that new end can the fourth piece's start
// be reached. Then 500 such lines at random
// angles, lengths and gaps, in chain order (shuffled sets rarely give this order).
TEST(Segments, MergeSearchesOnFromAPiecesNewEndInLaterSweeps) {
  auto make = MakeSegment;
  std::vector<Segment> v = {make({0, 0}, {10, 0}), make({14, 0}, {19, 0}), make({20, 0}, {74, 0}),
                            make({106, 0}, {176, 0})};
  std::vector<Segment> expected = v;
  // The oracle joins all four; the joins across 4 and 32 px (over merge_gap_px) keep their
  // pieces too: the first and the second-to-third's, then the first-to-third's and the fourth.
  ASSERT_EQ(MergeCollinearByXWindow(SegmentOptions{}, &expected), 4u);
  ASSERT_EQ(expected.size(), 5u);
  EXPECT_EQ(expected[1].a, v[0].a);
  EXPECT_EQ(expected[1].b, v[0].b);
  EXPECT_EQ(expected[2].b, v[2].b);
  EXPECT_EQ(expected[4].a, v[3].a);
  EXPECT_EQ(expected[4].b, v[3].b);
  EXPECT_TRUE(MergeCollinear(SegmentOptions{}, &v));
  ASSERT_EQ(v.size(), 5u);
  for (size_t i = 1; i < v.size(); ++i) {
    EXPECT_EQ(v[i].a, expected[i].a) << i;
    EXPECT_EQ(v[i].b, expected[i].b) << i;
    EXPECT_EQ(v[i].line, expected[i].line) << i;
  }
  EXPECT_EQ(v[0].a, expected[0].a);
  EXPECT_EQ(v[0].b, expected[0].b);
  EXPECT_EQ(v[0].line, expected[0].line);

  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0, 1);
  int joined_all = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector2d a(1000 * unit(rng), 1000 * unit(rng));
    const double angle = unit(rng) * 2 * M_PI;
    const Eigen::Vector2d u(std::cos(angle), std::sin(angle)), n(-u.y(), u.x());
    // (length, gap after it) of the four pieces, drawn one after the other.
    std::vector<std::pair<double, double>> pieces;
    for (const auto& [len_lo, len_span, gap_lo, gap_span] :
         {std::array<double, 4>{8, 7, 3.5, 3.5}, {3, 4, 0, 2}, {30, 50, 0, 45}, {60, 40, 0, 0}}) {
      const double len = len_lo + len_span * unit(rng);
      const double gap = gap_lo + gap_span * unit(rng);
      pieces.push_back({len, gap});
    }
    std::vector<Segment> w;
    double t = 0;
    for (const auto& [len, gap] : pieces) {
      const double off_a = 0.1 * (unit(rng) - 0.5);
      const double off_b = 0.1 * (unit(rng) - 0.5);
      w.push_back(make(a + t * u + off_a * n, a + (t + len) * u + off_b * n));
      t += len + gap;
    }
    std::vector<Segment> want = w;
    const size_t wide = MergeCollinearByXWindow(SegmentOptions{}, &want);
    EXPECT_TRUE(MergeCollinear(SegmentOptions{}, &w));
    joined_all += want.size() - wide == 1;
    ASSERT_EQ(w.size(), want.size()) << "trial " << trial;
    for (size_t i = 0; i < w.size(); ++i) {
      EXPECT_EQ(w[i].a, want[i].a) << "trial " << trial;
      EXPECT_EQ(w[i].b, want[i].b) << "trial " << trial;
      EXPECT_EQ(w[i].line, want[i].line) << "trial " << trial;
    }
  }
  EXPECT_GT(joined_all, 25);  // lines the later sweeps complete, or the family tests nothing
}

// The oracle for BridgeKinks' grid: every start within bridge_gap_px in x, in (x, index)
// order: the bridge without its grid.
void BridgeKinksByXWindow(const SegmentOptions& o, std::vector<Segment>* segs) {
  std::vector<Segment>& v = *segs;
  const size_t n = v.size();
  std::vector<std::pair<double, int>> by_x(n);
  for (size_t i = 0; i < n; ++i) by_x[i] = {v[i].a.x(), static_cast<int>(i)};
  std::sort(by_x.begin(), by_x.end());
  const double cos_max = std::cos(o.bridge_max_turn_deg * M_PI / 180);
  for (size_t i = 0; i < n; ++i) {
    const Segment s = v[i];
    const Eigen::Vector2d di = (s.b - s.a) / s.length();
    auto it =
        std::lower_bound(by_x.begin(), by_x.end(), std::make_pair(s.b.x() - o.bridge_gap_px, -1));
    for (; it != by_x.end() && it->first <= s.b.x() + o.bridge_gap_px; ++it) {
      const Segment& t = v[it->second];
      if (it->second == static_cast<int>(i) || (t.a - s.b).norm() > o.bridge_gap_px) continue;
      if (di.dot((t.b - t.a) / t.length()) < cos_max) continue;
      v.push_back(JoinSegments(s, t));
    }
  }
}

// Polylines of pieces bent by up to 30 degrees with gaps of up to 2 px, some pieces starting
// exactly where another ends or on a shared x, and short clutter: the bridges are those of a
// scan of the whole x window, in the same order, to the bit.
TEST(Segments, BridgeFindsWhatAScanOfTheXWindowFinds) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> pos(0, 400), unit(0, 1);
  size_t bridges = 0;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Segment> v;
    for (int e = 0; e < 60; ++e) {
      Eigen::Vector2d p = DrawVector2(pos, rng);
      double ang = unit(rng) * 2 * M_PI;
      for (int piece = 0; piece < 6; ++piece) {
        const Eigen::Vector2d u(std::cos(ang), std::sin(ang));
        const Eigen::Vector2d q = p + (4 + 20 * unit(rng)) * u;
        v.push_back(MakeSegment(p, q));
        // The next piece starts at the end itself, or up to 2 px away; some share its x.
        const double g = unit(rng) < 0.2 ? 0 : 2 * unit(rng);
        const double turn = (unit(rng) - 0.5) * 60 * M_PI / 180;
        p = q + g * Eigen::Vector2d(std::cos(ang + turn), std::sin(ang + turn));
        if (unit(rng) < 0.1) p.x() = q.x();
        ang += turn;
      }
    }
    AddClutter(1500, pos, rng, &v);
    std::shuffle(v.begin(), v.end(), rng);
    const size_t pieces = v.size();
    std::vector<Segment> expected = v;
    BridgeKinksByXWindow(SegmentOptions{}, &expected);
    BridgeKinks(SegmentOptions{}, &v);
    bridges += v.size() - pieces;
    ASSERT_EQ(v.size(), expected.size()) << "trial " << trial;
    for (size_t i = pieces; i < v.size(); ++i) {
      EXPECT_EQ(v[i].a, expected[i].a) << "trial " << trial << " " << i;
      EXPECT_EQ(v[i].b, expected[i].b) << "trial " << trial << " " << i;
      EXPECT_EQ(v[i].line, expected[i].line) << "trial " << trial << " " << i;
    }
  }
  EXPECT_GT(bridges, 20u * 100);  // or it would test nothing
}

// A side bent halfway by 7-14 degrees (a shadow across a small square's side) gets a segment
// over both pieces, the pieces stay; a corner, a gap or pieces going the other way do not.
TEST(Segments, BridgeSpansABentSideButNotACornerOrAGap) {
  auto make = MakeSegment;
  // The 30 px case of the comparison's size sweep: 7 degrees at (505.3, 622.1).
  std::vector<Segment> v = {make({499.7, 634.4}, {505.1, 622.0}),
                            make({505.5, 622.3}, {514.0, 608.0})};
  BridgeKinks(SegmentOptions{}, &v);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_NEAR(v[2].a.x(), 499.7, 1e-9);
  EXPECT_NEAR(v[2].b.y(), 608.0, 1e-9);
  EXPECT_NEAR(v[2].line.head<2>().norm(), 1.0, 1e-12);
  // Both ends lie within a pixel of the spanning line.
  for (const Eigen::Vector2d& p : {v[0].a, v[1].b})
    EXPECT_LT(std::abs(v[2].line.head<2>().dot(p) + v[2].line.z()), 1.0);
  // A corner (90 degrees), a 3 px gap, and a piece that runs back: nothing added.
  std::vector<Segment> corner = {make({0, 0}, {10, 0}), make({10, 0.5}, {10, 10})};
  std::vector<Segment> gap = {make({0, 0}, {10, 0}), make({13, 0.5}, {23, 1.5})};
  std::vector<Segment> back = {make({0, 0}, {10, 0}), make({10.5, 0.2}, {1, 0.5})};
  for (std::vector<Segment>* w : {&corner, &gap, &back}) {
    BridgeKinks(SegmentOptions{}, w);
    EXPECT_EQ(w->size(), 2u);
  }
  // Off: nothing added.
  SegmentOptions off;
  off.bridge_max_turn_deg = 0;
  std::vector<Segment> u = {make({0, 0}, {10, 0}), make({10.5, 0.2}, {20, 2})};
  BridgeKinks(off, &u);
  EXPECT_EQ(u.size(), 2u);
}

// Nested and adjacent squares do not hide one another: the white stripe of a marker on a dark
// skin is a bright frame whose inner border is the black square's border seen the other way.
// A dark square on a brighter plate with shot noise (variance grey / 64, what 16 sqrt(grey)
// assumes) plus `read` grey levels of read noise, rounded to 8 bits.
cv::Mat NoisySquare(double read, uint64_t seed) {
  cv::Mat img(240, 320, CV_8U, cv::Scalar(150));
  DrawSquare(img, 160, 120, 80, 10, 12);
  cv::RNG rng(seed);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double v = img.at<uint8_t>(y, x);
      img.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>(v + rng.gaussian(std::sqrt(v / 64 + read * read)));
    }
  return img;
}

TEST(Segments, ReadNoiseIsEstimatedAndDoesNotMultiplyTheEdges) {
  EXPECT_LT(EstimateReadNoise(NoisySquare(0, 1)), 0.6);
  EXPECT_LT(EstimateReadNoise(NoisySquare(1, 2)), SegmentOptions{}.read_noise_gate);
  EXPECT_NEAR(EstimateReadNoise(NoisySquare(4, 3)), 4, 0.6);
  EXPECT_NEAR(EstimateReadNoise(NoisySquare(8, 4)), 8, 1.0);
  EXPECT_EQ(EstimateReadNoise(cv::Mat(4, 4, CV_8U, cv::Scalar(9))), 0);
  // With 4 levels of read noise the black square's inside (level 12) is 12 levels of noise on
  // the plain 16 sqrt(grey) scale: noise edges everywhere, unless the scale allows for it.
  const cv::Mat noisy = NoisySquare(4, 5);
  cv::Mat gx, gy;
  SegmentOptions plain;
  plain.read_noise_gate = 1e9;
  const size_t adapted = FindSegments(noisy, SegmentOptions{}, &gx, &gy).size();
  const size_t unadapted = FindSegments(noisy, plain, &gx, &gy).size();
  RecordProperty("segments_adapted", static_cast<int>(adapted));
  RecordProperty("segments_plain_scale", static_cast<int>(unadapted));
  EXPECT_LE(adapted, 12u);
  EXPECT_GT(unadapted, 5 * adapted);
}

TEST(Segments, APassedDeadlineStopsTheEdgeChainsAndTheQuadSearch) {
  // A grid of 100 squares: hundreds of edge chains and segments. Under a deadline already
  // passed both steps stop at their first check and say so; without one (or one far off) they
  // finish and give the same segments and quads.
  cv::Mat img(400, 400, CV_8U, cv::Scalar(200));
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) DrawSquare(img, 20 + 40 * i, 20 + 40 * j, 24, 7 * i + j, 20);
  cv::Mat gx, gy;
  std::vector<Segment> all, part;
  ASSERT_TRUE(FindSegments(img, SegmentOptions{}, &gx, &gy, &all));
  ASSERT_GT(all.size(), 300u);
  const auto now = std::chrono::steady_clock::now();
  EXPECT_FALSE(FindSegments(img, SegmentOptions{}, &gx, &gy, &part, now - std::chrono::seconds(1)));
  EXPECT_LT(part.size(), all.size());
  ASSERT_TRUE(FindSegments(img, SegmentOptions{}, &gx, &gy, &part, now + std::chrono::hours(1)));
  EXPECT_EQ(part.size(), all.size());
  std::vector<Quad> quads, some;
  ASSERT_TRUE(FindQuads(all, QuadOptions{}, img.cols, img.rows, &quads));
  EXPECT_GE(quads.size(), 100u);
  EXPECT_FALSE(
      FindQuads(all, QuadOptions{}, img.cols, img.rows, &some, now - std::chrono::seconds(1)));
  EXPECT_LT(some.size(), quads.size());
}

// Steps 1-3 on several threads (the edge map in bands of rows, the chains fitted in chunks
// while they are linked, each chunk's segments put end to end) give the serial segments in the
// serial order, to the last bit, for 2, 3 and 7 threads, and from inside a task of the pool; the
// order matters (the collinear merge joins in it). The image has closed chains across the bands'
// borders, junctions, long lines through every band and thousands of short chains.
TEST(Segments, SeveralThreadsFindTheSameSegmentsInTheSameOrder) {
  // Clutter: 2,000 random grey quadrilaterals of 4-40 px over 60 squares (the detector
  // benchmark's busy frame, smaller), thin lines and rings through every strip.
  cv::Mat img(512, 640, CV_8U, cv::Scalar(128));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 60; ++i) {
    const double grey = 255 * u(rng), deg = 90 * u(rng), side = 10 + 60 * u(rng), y = 512 * u(rng),
                 x = 640 * u(rng);
    DrawSquare(img, x, y, side, deg, static_cast<uint8_t>(grey));
  }
  for (int i = 0; i < 2000; ++i) {
    const double cx = 640 * u(rng), cy = 512 * u(rng), r = 2 + 18 * u(rng), a = 6.3 * u(rng);
    std::vector<cv::Point> q;
    for (int k = 0; k < 4; ++k) {
      const double t = a + k * 1.5708 + 0.6 * (u(rng) - 0.5), rk = r * (0.7 + 0.6 * u(rng));
      q.emplace_back(cvRound(cx + rk * std::cos(t)), cvRound(cy + rk * std::sin(t)));
    }
    cv::fillConvexPoly(img, q, cv::Scalar(256 * u(rng)), cv::LINE_AA);
  }
  for (int k = 0; k < 6; ++k) {
    cv::line(img, cv::Point(20 + 100 * k, 0), cv::Point(60 + 100 * k, 511), cv::Scalar(240), 2);
    cv::circle(img, cv::Point(80 + 90 * k, 64 * (k + 1)), 30, cv::Scalar(10), 3);
  }
  cv::Mat noise(img.size(), CV_16S);
  cv::randn(noise, 0, 6);
  cv::add(img, noise, img, cv::noArray(), CV_8U);
  cv::Mat gx, gy;
  std::vector<Segment> serial, parallel;
  ASSERT_TRUE(FindSegments(img, SegmentOptions{}, &gx, &gy, &serial));
  ASSERT_GT(serial.size(), 2000u);
  const auto same = [&](const std::string& what) {
    ASSERT_EQ(parallel.size(), serial.size()) << what;
    for (size_t i = 0; i < serial.size(); ++i) {
      ASSERT_EQ(parallel[i].a, serial[i].a) << what << ", segment " << i;
      ASSERT_EQ(parallel[i].b, serial[i].b) << what << ", segment " << i;
      ASSERT_EQ(parallel[i].line, serial[i].line) << what << ", segment " << i;
      ASSERT_EQ(parallel[i].contrast, serial[i].contrast) << what << ", segment " << i;
    }
  };
  for (const int threads : {2, 3, 7}) {
    WorkerPool pool(threads);
    for (int frame = 0; frame < 2; ++frame) {  // the second on warmed-up buffers
      ASSERT_TRUE(FindSegments(img, SegmentOptions{}, &gx, &gy, &parallel,
                               std::chrono::steady_clock::time_point::max(), &pool));
      same(std::to_string(threads) + " threads");
    }
    // From inside one of the pool's own tasks the pool is busy, and every part of the frame
    // runs on that thread in order: the linking part first, then the fits that wait for it.
    bool nested_ok = false;
    pool.Run(2, [&](int part) {
      if (part == 0)
        nested_ok = FindSegments(img, SegmentOptions{}, &gx, &gy, &parallel,
                                 std::chrono::steady_clock::time_point::max(), &pool);
    });
    ASSERT_TRUE(nested_ok);
    same(std::to_string(threads) + " threads, called from the pool's own task");
  }
}

TEST(Quads, NestedAndAdjacentSquaresAreAllFound) {
  cv::Mat img(200, 300, CV_8U, cv::Scalar(200));
  DrawSquare(img, 100, 100, 120, 5, 20);                    // dark skin
  DrawSquare(img, 100, 100, 80, 5, 200);                    // white stripe
  const auto inner = DrawSquare(img, 100, 100, 40, 5, 20);  // black square
  const auto beside = DrawSquare(img, 230, 100, 50, -12, 20);
  cv::Mat gx, gy;
  const std::vector<Segment> segs = FindSegments(img, SegmentOptions{}, &gx, &gy);
  const std::vector<Quad> quads = FindQuads(segs, QuadOptions{}, img.cols, img.rows);
  auto found = [&](const std::array<Eigen::Vector2d, 4>& truth) {
    for (const Quad& q : quads)
      for (int r = 0; r < 4; ++r) {
        double worst = 0;
        for (int k = 0; k < 4; ++k)
          worst = std::max(worst, (q.corners[(k + r) % 4] - truth[k]).norm());
        if (worst < 1.0) return true;
      }
    return false;
  };
  EXPECT_TRUE(found(inner));
  EXPECT_TRUE(found(beside));
  // The outer skin square (dark on the right when walked clockwise) is found too.
  const double a = 5 * M_PI / 180;
  const Eigen::Vector2d u(std::cos(a), std::sin(a)), v(-std::sin(a), std::cos(a)), c(100, 100);
  EXPECT_TRUE(
      found({c - 60 * u - 60 * v, c + 60 * u - 60 * v, c + 60 * u + 60 * v, c - 60 * u + 60 * v}));
}

}  // namespace
}  // namespace svms
