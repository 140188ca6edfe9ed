#include "svms/marker/layout.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "svms/base/random_draws.h"

namespace svms {
namespace {

LayoutEntry At(int id, double size, const Eigen::Vector3d& tvec,
               const Eigen::Vector3d& rvec = Eigen::Vector3d::Zero()) {
  LayoutEntry e;
  e.marker = MarkerModel::Standard(id, size, 0.01);
  e.object_from_marker.rvec = rvec;
  e.object_from_marker.tvec = tvec;
  return e;
}

// A rows x cols board of markers of black square `size`, printed side 2 * size, `gap` apart.
Layout Board(int rows, int cols, double size, double gap) {
  Layout l;
  l.name = "board";
  const double pitch = 2 * size + gap;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      l.markers.push_back(At(r * cols + c, size, Eigen::Vector3d(c * pitch, -r * pitch, 0)));
  return l;
}

void ExpectError(const Layout& l, std::initializer_list<std::string> parts) {
  const Status s = l.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
  for (const std::string& p : parts)
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
}

TEST(LayoutOverlap, BoardsWithAndWithoutGapsAreFine) {
  EXPECT_TRUE(Board(5, 6, 0.06, 0.015).Validate().ok());
  const Status s = Board(5, 6, 0.06, 0).Validate();  // touching markers
  EXPECT_TRUE(s.ok()) << s.message();
}

TEST(LayoutOverlap, SurveyNoiseOnATouchingBoardIsTolerated) {
  Layout l = Board(4, 4, 0.1, 0);
  std::mt19937 rng(3);
  std::normal_distribution<double> mm(0, 3e-4), rad(0, 1e-3);
  for (LayoutEntry& e : l.markers) {
    e.object_from_marker.tvec += DrawVector3(mm, rng);  // fixed order (random_draws.h)
    e.object_from_marker.rvec += DrawVector3(rad, rng);
  }
  const Status s = l.Validate();
  EXPECT_TRUE(s.ok()) << s.message();
}

TEST(LayoutOverlap, CoplanarSquaresThatIntersectAreRejected) {
  Layout l;
  l.markers = {At(1, 0.1, {0, 0, 0}), At(2, 0.1, {0.15, 0, 0})};  // printed sides 0.2 m
  ExpectError(l, {"markers[1].object_from_marker: marker 2 overlaps markers[0]",
                  "printed square (0.2 m", "overlaps that of marker 1", "same plane"});
  // The same on a tilted plane, the second marker turned by 45 degrees in it.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()).matrix();
  const Pose a = Pose::FromRotation(R, {1, 2, 3});
  const Pose b = Pose::FromRotation(R * Rz, R * Eigen::Vector3d(0.2, 0.05, 0) + a.tvec);
  l.markers = {At(1, 0.1, a.tvec, a.rvec), At(2, 0.1, b.tvec, b.rvec)};
  ExpectError(l, {"marker 2 overlaps markers[0]", "same plane"});
  // Far enough apart on that plane: fine (the rotated square's half-diagonal is 0.1414 m).
  const Pose c = Pose::FromRotation(R * Rz, R * Eigen::Vector3d(0.25, 0, 0) + a.tvec);
  l.markers = {At(1, 0.1, a.tvec, a.rvec), At(2, 0.1, c.tvec, c.rvec)};
  const Status s = l.Validate();
  EXPECT_TRUE(s.ok()) << s.message();
}

TEST(LayoutOverlap, ASmallMarkerOnABigOnesRingIsRejected) {
  Layout l;
  l.markers = {At(1, 0.4, {0, 0, 0}), At(2, 0.05, {0.35, 0.35, 0.001})};
  ExpectError(l, {"marker 2 overlaps markers[0]", "that of marker 1 (0.8 m)"});
}

TEST(LayoutOverlap, CentresTooCloseAreRejectedWhateverTheOrientation) {
  Layout l;
  l.markers = {At(1, 0.1, {0, 0, 0}), At(2, 0.2, {0.03, 0, 0.02}, Eigen::Vector3d(M_PI / 2, 0, 0))};
  ExpectError(l, {"marker 2 overlaps markers[0]", "its centre is 0.03606 m from that of marker 1",
                  "closer than half the smaller black square (0.05 m)"});
}

TEST(LayoutOverlap, MarkersOnDifferentFacesMayMeetAtAnEdge) {
  // A 0.4 m cube: a marker on the top face and one on the front face, both at the shared edge.
  Layout l;
  l.markers = {At(1, 0.1, {0, 0.1, 0.2}),
               At(2, 0.1, {0, 0.2, 0.1}, Eigen::Vector3d(-M_PI / 2, 0, 0))};
  const Status s = l.Validate();
  EXPECT_TRUE(s.ok()) << s.message();
  // Parallel planes 5 cm apart (a marker on a standoff over another): not the same plane.
  l.markers = {At(1, 0.1, {0, 0, 0}), At(2, 0.1, {0.12, 0, 0.05})};
  EXPECT_TRUE(l.Validate().ok());
}

TEST(LayoutOverlap, ADualWrittenAsTwoEntriesIsFine) {
  // `svms survey` writes the two markers of a dual as two entries, a hair apart.
  Layout l;
  l.markers = {At(100, 0.3, {1, 2, 3}, {0.1, 0.2, 0.3}),
               At(150, 0.075, {1 + 2e-5, 2, 3}, {0.1, 0.2, 0.3 + 1e-4})};
  Status s = l.Validate();
  EXPECT_TRUE(s.ok()) << s.message();
  std::swap(l.markers[0], l.markers[1]);
  s = l.Validate();
  EXPECT_TRUE(s.ok()) << s.message();
  // An inner marker too big for the black square (its ring on the outer's stripe) overlaps.
  l.markers = {At(100, 0.3, {0, 0, 0}), At(150, 0.2, {0, 0, 0})};
  ExpectError(l, {"marker 150 overlaps markers[0]: its centre is 0 m from that of marker 100"});
}

TEST(LayoutBadNumbers, EachIsNamed) {
  Layout l = Board(1, 2, 0.1, 0.05);
  l.markers[1].object_from_marker.tvec.x() = std::nan("");
  ExpectError(l, {"markers[1].object_from_marker: expected finite rvec and tvec"});
  l = Board(1, 2, 0.1, 0.05);
  l.markers[0].object_from_marker.rvec.z() = INFINITY;
  ExpectError(l, {"markers[0].object_from_marker: expected finite"});
  l = Board(1, 2, 0.1, 0.05);
  l.markers[0].covariance = PoseCovariance::Identity();
  (*l.markers[0].covariance)(2, 2) = std::nan("");
  ExpectError(l, {"markers[0].covariance: expected 36 finite numbers"});
  l = Board(1, 2, 0.1, 0.05);
  l.markers[1].post_height_sigma = -1e-4;
  ExpectError(l, {"markers[1].post_height_sigma: expected a non-negative"});
  l.markers[1].post_height_sigma = INFINITY;
  ExpectError(l, {"markers[1].post_height_sigma: expected a non-negative"});
  l = Board(1, 2, 0.1, 0.05);
  l.markers[1].marker.size = 0;
  ExpectError(l, {"markers[1].marker.size: expected a positive number of metres, got 0"});
  l.markers[1].marker.size = std::nan("");
  ExpectError(l, {"markers[1].marker.size: expected a positive number of metres, got nan"});
  // An inner marker's ID may not repeat another entry's outer ID.
  l = Board(1, 2, 0.1, 0.05);
  l.markers[1].marker.AddInner(0, 0.025);
  ExpectError(l, {"markers[1].marker.id: ID 0 appears twice (also in markers[0])"});
  l.markers.clear();
  ExpectError(l, {"markers: expected at least one marker"});
}

}  // namespace
}  // namespace svms
