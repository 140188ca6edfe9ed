#include "svms/calib/board_grid.h"

#include <gtest/gtest.h>

#include "svms/calib/board.h"

namespace svms {
namespace {

std::vector<Eigen::Vector3d> BoardCorners(const BoardSpec& spec) {
  std::vector<Eigen::Vector3d> points;
  for (const LayoutEntry& e : MakeBoardLayout(spec).markers)
    for (const Eigen::Vector3d& c : e.marker.Corners()) points.push_back(e.object_from_marker * c);
  return points;
}

TEST(BoardGrid, DefaultBoardIsAGridOfQuarterSizes) {
  // size 0.06, gap 0.015: pitch 0.135 = 9 x 0.015, side 0.06 = 4 x 0.015.
  const BoardSpec spec{5, 6, 0.06, 0.015, 100};
  const std::vector<Eigen::Vector3d> points = BoardCorners(spec);
  BoardGrid g;
  ASSERT_TRUE(FindBoardGrid(points, 1e-7, 100000, &g).ok());
  EXPECT_NEAR(g.spacing, 0.015, 1e-12);
  EXPECT_EQ(g.width, 5 * 9 + 4 + 1);  // 5 pitches and one side, in spacings
  EXPECT_EQ(g.height, 4 * 9 + 4 + 1);
  EXPECT_NEAR(g.origin.x(), -2.5 * 0.135 - 0.03, 1e-12);
  EXPECT_NEAR(g.origin.y(), -2 * 0.135 - 0.03, 1e-12);
  // Every corner on its own node, at that node's point.
  std::vector<int> seen(g.width * g.height, 0);
  for (const Eigen::Vector3d& p : points) {
    int i = -1, j = -1;
    ASSERT_TRUE(g.Node(p, 1e-9, &i, &j));
    EXPECT_LT((g.Point(i, j) - p).norm(), 1e-12);
    EXPECT_EQ(seen[i * g.width + j]++, 0);
  }
  // Rows go up the board (y), columns to the right (x): the top-left marker's top-left corner
  // is in the last row, first column.
  int i, j;
  ASSERT_TRUE(g.Node(points[0], 1e-9, &i, &j));
  EXPECT_EQ(i, g.height - 1);
  EXPECT_EQ(j, 0);
  // A point between nodes is off the grid.
  EXPECT_FALSE(g.Node(points[0] + Eigen::Vector3d(0.004, 0, 0), 1e-9, &i, &j));
}

TEST(BoardGrid, RefusesWhatMrcalCannotHold) {
  BoardGrid g;
  // Incommensurate side and pitch: the common spacing is too fine.
  const BoardSpec odd{2, 2, 0.05, 0.0123456789, 0};
  const Status s = FindBoardGrid(BoardCorners(odd), 1e-9, 10000, &g);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no regular grid"), std::string::npos) << s.message();
  // A post tip off the plane.
  std::vector<Eigen::Vector3d> points = BoardCorners(BoardSpec{2, 2, 0.05, 0.01, 0});
  points.emplace_back(0, 0, 0.01);
  EXPECT_NE(FindBoardGrid(points, 1e-7, 10000, &g).message().find("post tip"), std::string::npos);
  // A line of points spans no area; nothing at all.
  EXPECT_FALSE(FindBoardGrid({{0, 0, 0}, {0.1, 0, 0}}, 1e-7, 10000, &g).ok());
  EXPECT_FALSE(FindBoardGrid({}, 1e-7, 10000, &g).ok());
  // One spacing serves x and y: 0.3 by 0.1 is 4 x 2 nodes at 0.1.
  ASSERT_TRUE(FindBoardGrid({{0, 0, 0}, {0.3, 0, 0}, {0, 0.1, 0}}, 1e-7, 10000, &g).ok());
  EXPECT_NEAR(g.spacing, 0.1, 1e-12);
  EXPECT_EQ(g.width, 4);
  EXPECT_EQ(g.height, 2);
}

}  // namespace
}  // namespace svms
