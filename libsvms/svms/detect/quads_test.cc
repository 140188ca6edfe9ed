#include "svms/detect/quads.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "svms/detect/worker_pool.h"

namespace svms {
namespace {

// The segment from a to b, its line through both (dark side on the right walking a -> b).
Segment MakeSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  Segment s;
  s.a = a;
  s.b = b;
  const Eigen::Vector2d d = (b - a).normalized();
  const Eigen::Vector2d n(-d.y(), d.x());
  s.line = Eigen::Vector3d(n.x(), n.y(), -n.dot(a));
  s.contrast = 50;
  return s;
}

// The four sides of a square of `side` px about `centre`, turned by `deg`, clockwise on
// screen, each cut short by `rounding` px at both ends (the rounded corners of a small
// blurred square); and its true corners.
struct SmallSquare {
  std::array<Eigen::Vector2d, 4> corners;
  std::vector<Segment> sides;
};
SmallSquare MakeSmallSquare(const Eigen::Vector2d& centre, double side, double deg,
                            double rounding) {
  const double a = deg * M_PI / 180;
  const Eigen::Vector2d u(std::cos(a), std::sin(a)), v(-std::sin(a), std::cos(a));
  SmallSquare sq;
  const double h = side / 2;
  sq.corners = {centre - h * u - h * v, centre + h * u - h * v, centre + h * u + h * v,
                centre - h * u + h * v};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = sq.corners[k], q = sq.corners[(k + 1) % 4];
    const Eigen::Vector2d d = (q - p).normalized();
    sq.sides.push_back(MakeSegment(p + rounding * d, q - rounding * d));
  }
  return sq;
}

// Corner k of `q` against corner (k + r) % 4 of `truth`, the worst over k, at the best r.
double WorstCornerError(const Quad& q, const std::array<Eigen::Vector2d, 4>& truth) {
  double best = 1e300;
  for (int r = 0; r < 4; ++r) {
    double worst = 0;
    for (int k = 0; k < 4; ++k) worst = std::max(worst, (q.corners[k] - truth[(k + r) % 4]).norm());
    best = std::min(best, worst);
  }
  return best;
}

TEST(Quads, IntersectGivesTheCrossingAndRejectsParallelLines) {
  Eigen::Vector2d p;
  ASSERT_TRUE(Intersect({1, 0, -3}, {0, 1, -4}, &p));  // x = 3, y = 4
  EXPECT_NEAR(p.x(), 3, 1e-12);
  EXPECT_NEAR(p.y(), 4, 1e-12);
  EXPECT_FALSE(Intersect({1, 0, -3}, {1, 0, -5}, &p));
}

// A small square with all four sides gives its quad once, none of its 3-chains completed.
TEST(Quads, ACompleteSmallSquareIsNotCompletedAgain) {
  for (const double deg : {0.0, 17.0, 45.0, 71.0}) {
    const SmallSquare sq = MakeSmallSquare({50, 40}, 9, deg, 1.5);
    const std::vector<Quad> quads = FindQuads(sq.sides, QuadOptions{}, 100, 80);
    ASSERT_EQ(quads.size(), 1u) << deg << " degrees";
    EXPECT_FALSE(quads[0].completed);
    EXPECT_LT(WorstCornerError(quads[0], sq.corners), 1e-9);
  }
}

// Step 4b: with any one side of a small square missing, the other three give a quad whose
// side 3 is inferred; a square's missing corners are exact (a parallelogram with the middle
// side's length), its known corners the segments' intersections.
TEST(Quads, ThreeSidesOfASmallSquareAreCompleted) {
  for (const double side : {7.0, 9.0, 11.5}) {
    for (const double deg : {0.0, 17.0, 45.0, 71.0}) {
      const SmallSquare sq = MakeSmallSquare({50, 40}, side, deg, 1.5);
      for (int missing = 0; missing < 4; ++missing) {
        SCOPED_TRACE(std::to_string(side) + " px, " + std::to_string(deg) + " degrees, side " +
                     std::to_string(missing) + " missing");
        std::vector<Segment> three;
        for (int k = 0; k < 4; ++k)
          if (k != missing) three.push_back(sq.sides[k]);
        const std::vector<Quad> quads = FindQuads(three, QuadOptions{}, 100, 80);
        ASSERT_EQ(quads.size(), 1u);
        const Quad& q = quads[0];
        EXPECT_TRUE(q.completed);
        EXPECT_EQ(q.sides[3], -1);
        for (int k = 0; k < 3; ++k) ASSERT_GE(q.sides[k], 0);
        EXPECT_LT(WorstCornerError(q, sq.corners), 1e-9);
        // Corner k is where side k - 1 meets side k: corners 1 and 2 are the known ones.
        for (int k = 1; k <= 2; ++k) {
          Eigen::Vector2d p;
          ASSERT_TRUE(Intersect(three[q.sides[k - 1]].line, three[q.sides[k]].line, &p));
          EXPECT_LT((q.corners[k] - p).norm(), 1e-9) << "corner " << k;
        }
      }
    }
  }
}

// Under perspective the inferred corners are off by about how much the two known sides differ
// in length, and still within the 1-3 px that step 8's fit starts from.
TEST(Quads, AForeshortenedSquaresInferredCornersAreNearItsOwn) {
  // A trapezoid: the top 8 px wide, the bottom 10, 9 px tall.
  const std::array<Eigen::Vector2d, 4> corners = {
      Eigen::Vector2d(46, 35.5), Eigen::Vector2d(54, 35.5), Eigen::Vector2d(55, 44.5),
      Eigen::Vector2d(45, 44.5)};
  std::vector<Segment> three;
  for (int k = 1; k < 4; ++k) {  // the top is missing
    const Eigen::Vector2d p = corners[k], q = corners[(k + 1) % 4];
    const Eigen::Vector2d d = (q - p).normalized();
    three.push_back(MakeSegment(p + 1.5 * d, q - 1.5 * d));
  }
  const std::vector<Quad> quads = FindQuads(three, QuadOptions{}, 100, 80);
  ASSERT_EQ(quads.size(), 1u);
  EXPECT_TRUE(quads[0].completed);
  const double worst = WorstCornerError(quads[0], corners);
  EXPECT_GT(worst, 0.1);
  EXPECT_LT(worst, 1.5);
}

// Only small squares are completed (their corners round off; a large square's sides are whole),
// never with the option off, and never two sides alone or three that do not turn right.
TEST(Quads, OnlySmallThreeSidedChainsAreCompleted) {
  const SmallSquare large = MakeSmallSquare({50, 40}, 20, 10, 1.5);
  const std::vector<Segment> three_large(large.sides.begin(), large.sides.begin() + 3);
  EXPECT_TRUE(FindQuads(three_large, QuadOptions{}, 100, 80).empty());

  const SmallSquare small = MakeSmallSquare({50, 40}, 9, 10, 1.5);
  const std::vector<Segment> three(small.sides.begin(), small.sides.begin() + 3);
  QuadOptions off;
  off.complete_below_px = 0;
  EXPECT_TRUE(FindQuads(three, off, 100, 80).empty());
  QuadOptions below_nine;
  below_nine.complete_below_px = 8.5;  // the middle side, 9 px corner to corner, is too long
  EXPECT_TRUE(FindQuads(three, below_nine, 100, 80).empty());

  // The first and third sides 50 degrees from antiparallel (40 allowed): a side of 8 px going
  // right, one of 10 px going down, one of 8 px leaving down and to the left.
  const double a50 = 50 * M_PI / 180;
  const Eigen::Vector2d c1(50, 35), c2(50, 45);
  const Eigen::Vector2d c0 = c1 - Eigen::Vector2d(8, 0);
  const Eigen::Vector2d c3 = c2 + 8 * Eigen::Vector2d(-std::cos(a50), std::sin(a50));
  auto cut = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
    const Eigen::Vector2d d = (q - p).normalized();
    return MakeSegment(p + 1.5 * d, q - 1.5 * d);
  };
  const std::vector<Segment> skewed = {cut(c0, c1), cut(c1, c2), cut(c2, c3)};
  EXPECT_TRUE(FindQuads(skewed, QuadOptions{}, 100, 80).empty());
  QuadOptions wide_skew;
  wide_skew.complete_max_skew_deg = 55;
  EXPECT_EQ(FindQuads(skewed, wide_skew, 100, 80).size(), 1u);

  // A middle side under QuadOptions::min_side (6 px) corner to corner.
  const SmallSquare tiny = MakeSmallSquare({50, 40}, 5.5, 10, 0.5);
  const std::vector<Segment> tiny_three(tiny.sides.begin(), tiny.sides.begin() + 3);
  EXPECT_TRUE(FindQuads(tiny_three, QuadOptions{}, 100, 80).empty());
  QuadOptions small_min;
  small_min.min_side = 5;
  EXPECT_EQ(FindQuads(tiny_three, small_min, 100, 80).size(), 1u);

  const std::vector<Segment> two(small.sides.begin(), small.sides.begin() + 2);
  EXPECT_TRUE(FindQuads(two, QuadOptions{}, 100, 80).empty());

  // The light square's sides (dark outside) turn left: no chain.
  std::vector<Segment> reversed;
  for (int k = 2; k >= 0; --k) reversed.push_back(MakeSegment(three[k].b, three[k].a));
  EXPECT_TRUE(FindQuads(reversed, QuadOptions{}, 100, 80).empty());

  // Inferred corners outside the image are not kept: the top's, 1.5 px above it.
  const SmallSquare at_edge = MakeSmallSquare({50, 3}, 9, 0, 1.5);
  const std::vector<Segment> edge_three(at_edge.sides.begin() + 1, at_edge.sides.end());
  EXPECT_TRUE(FindQuads(edge_three, QuadOptions{}, 100, 80).empty());
}

// The quad search on several threads (by first side, each part's quads put end to end) gives
// the serial quads in the serial order, to the last bit, for 2, 3 and 7 threads: with the
// search whole, and with max_quads cutting it within the 4-cycles and within step 4b's
// completed quads (the serial search stops starting first sides at that count), each capped
// list checked against the whole one cut by that rule.
TEST(Quads, SeveralThreadsFindTheSameQuadsInTheSameOrder) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Segment> segs;
  // 500 squares of 6-40 px, a fifth of them under 12 px with a side missing (4b's case), in a
  // 640 x 480 frame, among 1,500 random segments of 4-30 px.
  for (int k = 0; k < 500; ++k) {
    const double side = 6 + 34 * u(rng);
    SmallSquare sq = MakeSmallSquare(Eigen::Vector2d(20 + 600 * u(rng), 20 + 440 * u(rng)), side,
                                     90 * u(rng), 0.15 * side * u(rng));
    const bool three_sided = side < 12 && u(rng) < 0.5;
    for (int e = 0; e < (three_sided ? 3 : 4); ++e) segs.push_back(sq.sides[e]);
  }
  for (int k = 0; k < 1500; ++k) {
    const Eigen::Vector2d a(640 * u(rng), 480 * u(rng));
    const double length = 4 + 26 * u(rng), t = 6.2832 * u(rng);
    segs.push_back(MakeSegment(a, a + length * Eigen::Vector2d(std::cos(t), std::sin(t))));
  }
  std::shuffle(segs.begin(), segs.end(), rng);
  const auto same = [](const std::vector<Quad>& p, const std::vector<Quad>& q,
                       const std::string& what) {
    ASSERT_EQ(p.size(), q.size()) << what;
    for (size_t i = 0; i < p.size(); ++i) {
      ASSERT_EQ(p[i].sides, q[i].sides) << what << ", quad " << i;
      ASSERT_EQ(p[i].completed, q[i].completed) << what << ", quad " << i;
      for (int e = 0; e < 4; ++e)
        ASSERT_EQ(p[i].corners[e], q[i].corners[e]) << what << ", quad " << i;
    }
  };
  QuadOptions whole;
  whole.max_quads = 1000000;
  std::vector<Quad> serial;
  ASSERT_TRUE(FindQuads(segs, whole, 640, 480, &serial));
  int cycles = 0;
  for (const Quad& q : serial) cycles += !q.completed;
  const int completed = static_cast<int>(serial.size()) - cycles;
  ASSERT_GT(cycles, 300);
  ASSERT_GT(completed, 40);
  // What a cap leaves of the whole list, by the serial search's rule written out here: first
  // sides in increasing order, a side's quads taken whole, no further first side once the list
  // holds the cap; the completed quads after the 4-cycles, counting them.
  const auto capped = [&](int cap) {
    std::vector<Quad> out;
    bool in_completed = false;
    int current = -1;
    size_t before = 0;
    for (const Quad& q : serial) {
      if (q.completed && !in_completed) in_completed = true, current = -1;
      if (q.sides[0] != current) current = q.sides[0], before = out.size();
      if (static_cast<int>(before) < cap) out.push_back(q);
    }
    return out;
  };
  // Caps: none, within the first part's 4-cycles (each part then stops on its own count),
  // within the 4-cycles, within the completed quads.
  for (const int cap : {whole.max_quads, cycles / 20, cycles / 2, cycles + completed / 2}) {
    QuadOptions o = whole;
    o.max_quads = cap;
    std::vector<Quad> one, several;
    ASSERT_TRUE(FindQuads(segs, o, 640, 480, &one));
    same(capped(cap), one, "cap " + std::to_string(cap) + ", one thread");
    if (cap < whole.max_quads) {
      ASSERT_LT(one.size(), serial.size());
    }
    for (const int threads : {2, 3, 7}) {
      WorkerPool pool(threads);
      for (int frame = 0; frame < 2; ++frame) {  // the second on warmed-up buffers
        ASSERT_TRUE(FindQuads(segs, o, 640, 480, &several,
                              std::chrono::steady_clock::time_point::max(), &pool));
        same(one, several,
             "cap " + std::to_string(cap) + ", " + std::to_string(threads) + " threads");
      }
    }
  }
}

}  // namespace
}  // namespace svms
