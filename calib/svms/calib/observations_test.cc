#include "svms/calib/observations.h"

#include <gtest/gtest.h>

#include "svms/marker/marker_model.h"

namespace svms {
namespace {

// Moves each side of the quad outward by `d` pixels and intersects the moved sides: where the
// corners of a black square seen `d` px larger lie.
std::array<Eigen::Vector2d, 4> GrownQuad(const std::array<Eigen::Vector2d, 4>& c, double d) {
  const Eigen::Vector2d centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  std::array<Eigen::Vector3d, 4> line;  // a x + b y + c = 0, (a, b) the outward unit normal
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = c[k], q = c[(k + 1) % 4];
    Eigen::Vector2d n = Eigen::Vector2d(q.y() - p.y(), p.x() - q.x()).normalized();
    if (n.dot(p - centre) < 0) n = -n;
    line[k] = Eigen::Vector3d(n.x(), n.y(), -n.dot(p) - d);
  }
  std::array<Eigen::Vector2d, 4> out;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d x = line[(k + 3) % 4].cross(line[k]);
    out[k] = x.head<2>() / x.z();
  }
  return out;
}

TEST(QuadEdgeShifts, SquareHeadOnMovesAlongTheDiagonals) {
  // Image axes: x right, y down; corners TL TR BR BL.
  const std::array<Eigen::Vector2d, 4> c = {Eigen::Vector2d(10, 10), Eigen::Vector2d(30, 10),
                                            Eigen::Vector2d(30, 30), Eigen::Vector2d(10, 30)};
  const auto s = QuadEdgeShifts(c);
  EXPECT_NEAR((s[0] - Eigen::Vector2d(-1, -1)).norm(), 0, 1e-12);
  EXPECT_NEAR((s[1] - Eigen::Vector2d(1, -1)).norm(), 0, 1e-12);
  EXPECT_NEAR((s[2] - Eigen::Vector2d(1, 1)).norm(), 0, 1e-12);
  EXPECT_NEAR((s[3] - Eigen::Vector2d(-1, 1)).norm(), 0, 1e-12);
}

TEST(QuadEdgeShifts, MatchesTheGrownQuadEitherWinding) {
  // A perspective quad (sides at 60-120 degrees to each other), in both windings: the shift
  // times d is where the corners of the quad grown by d px lie.
  std::array<Eigen::Vector2d, 4> c = {Eigen::Vector2d(100, 80), Eigen::Vector2d(160, 95),
                                      Eigen::Vector2d(150, 170), Eigen::Vector2d(90, 140)};
  for (int winding = 0; winding < 2; ++winding) {
    if (winding == 1) std::swap(c[1], c[3]);
    const auto s = QuadEdgeShifts(c);
    const double d = 0.01;
    const auto grown = GrownQuad(c, d);
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR((c[k] + d * s[k] - grown[k]).norm(), 0, 1e-9) << winding << " " << k;
  }
}

TEST(QuadEdgeShifts, ZeroWhereSidesAreParallel) {
  // Corner 1 repeated: its sides are degenerate; no shift is made up.
  const std::array<Eigen::Vector2d, 4> c = {Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 0),
                                            Eigen::Vector2d(10, 0), Eigen::Vector2d(0, 10)};
  const auto s = QuadEdgeShifts(c);
  EXPECT_EQ(s[1], Eigen::Vector2d::Zero());
  EXPECT_EQ(s[2], Eigen::Vector2d::Zero());
}

TEST(ObservationsFromDetections, CornersCarryTheirShiftTheTipNone) {
  Layout layout;
  LayoutEntry e;
  e.marker = MarkerModel::Standard(7, 0.06, 0.015);
  layout.markers.push_back(e);
  Detection d;
  d.id = 7;
  d.corners = {Eigen::Vector2d(10, 10), Eigen::Vector2d(30, 10), Eigen::Vector2d(30, 30),
               Eigen::Vector2d(10, 30)};
  d.tip = TipObservation();
  d.tip->pixel = Eigen::Vector2d(20, 20);
  d.tip->sigma_px = 0.05;
  const ViewObservations v = ObservationsFromDetections({d}, layout, "view", 0.1);
  ASSERT_EQ(v.points.size(), 5u);
  EXPECT_NEAR((v.points[2].edge_shift - Eigen::Vector2d(1, 1)).norm(), 0, 1e-12);
  EXPECT_EQ(v.points[4].corner, PointObservation::kTip);
  EXPECT_EQ(v.points[4].edge_shift, Eigen::Vector2d::Zero());
}

}  // namespace
}  // namespace svms
