#include "svms/geometry/quad_sides.h"

#include <gtest/gtest.h>

#include <cmath>

namespace svms {
namespace {

// A quad turned by `angle` about (cx, cy), with sides of half-lengths hx, hy, wound one way or
// the other.
std::array<Eigen::Vector2d, 4> Rectangle(double cx, double cy, double hx, double hy, double angle,
                                         bool reversed) {
  const Eigen::Vector2d c(cx, cy);
  const Eigen::Vector2d u(std::cos(angle), std::sin(angle)), v(-std::sin(angle), std::cos(angle));
  std::array<Eigen::Vector2d, 4> q = {c - hx * u - hy * v, c + hx * u - hy * v, c + hx * u + hy * v,
                                      c - hx * u + hy * v};
  if (reversed) std::swap(q[1], q[3]);
  return q;
}

TEST(QuadSides, NormalsPointOutOfTheQuadEitherWinding) {
  for (const bool reversed : {false, true}) {
    for (double angle = -3; angle < 3.2; angle += 0.37) {
      const auto q = Rectangle(40, -7, 12, 5, angle, reversed);
      const auto n = QuadOutwardNormals(q);
      const Eigen::Vector2d centre = QuadCentroid(q);
      EXPECT_NEAR((centre - Eigen::Vector2d(40, -7)).norm(), 0, 1e-12);
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d a = q[k], b = q[(k + 1) % 4], mid = 0.5 * (a + b);
        EXPECT_NEAR(n[k].norm(), 1, 1e-12);
        EXPECT_NEAR(n[k].dot(b - a), 0, 1e-9);
        // The side's midpoint lies half a side out from the centre along its normal.
        EXPECT_NEAR(n[k].dot(mid - centre), k % 2 == (reversed ? 1 : 0) ? 5 : 12, 1e-9)
            << "side " << k << " angle " << angle;
      }
    }
  }
}

TEST(QuadSides, PerspectiveQuadAndDegenerateSide) {
  // A general convex quad (no two sides parallel, as a tilted square projects): every side's
  // outward normal points away from the corners not on that side.
  const std::array<Eigen::Vector2d, 4> q = {Eigen::Vector2d(0, 0), Eigen::Vector2d(20, 3),
                                            Eigen::Vector2d(19, 14), Eigen::Vector2d(2, 17)};
  const auto n = QuadOutwardNormals(q);
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < 4; ++j) {
      if (j == k || j == (k + 1) % 4) continue;
      EXPECT_LT(n[k].dot(q[j] - q[k]), 0) << k << " " << j;
    }
  }
  EXPECT_EQ(OutwardNormal(q[1], q[1], QuadCentroid(q)), Eigen::Vector2d::Zero());
  // A centre at the side's midpoint (on its line; exact in binary here): the normal to the right
  // of a -> b with y down, (-d.y, d.x) / |d|, for either direction of the side.
  const Eigen::Vector2d a(3, 4), b(7, 1), mid(5, 2.5);
  EXPECT_EQ(OutwardNormal(a, b, mid), Eigen::Vector2d(0.6, 0.8));
  EXPECT_EQ(OutwardNormal(b, a, mid), Eigen::Vector2d(-0.6, -0.8));
}

}  // namespace
}  // namespace svms
