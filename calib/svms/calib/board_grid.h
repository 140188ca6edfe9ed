// mrcal's calibration object is a regular grid: W x H points at one spacing in x and y, in the
// z = 0 plane, and a board observation is a W x H array of pixels with a weight per point
// (weight <= 0: not seen, or an outlier). An SVMS board (board.h) is not a chessboard: its
// points are the corners of markers, `size` apart across a marker and `pitch` apart from one
// marker to the next. They still lie on a regular grid when size and pitch are whole multiples of
// one spacing (the default board: size 0.06 m, gap 0.015 m, so pitch 0.135 m; spacing 0.015 m,
// 50 x 41 nodes of which 120 are corners). This finds that grid, so that a calibration on such
// a board can be handed to mrcal's tools; the nodes that are no corner are written as unseen.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "svms/base/status.h"

namespace svms {

// The grid of mrcal's calibration object in the board frame (board.h): node (i, j) (row i,
// column j) is at origin + (j * spacing, i * spacing, 0). The mrcal object frame is the board
// frame translated by `origin` (same axes, so mrcal's warp, along z, is the board's warp along
// z, and its x, y scaling over the grid is BoardExtent's over the same rectangle).
struct BoardGrid {
  double spacing = 0;                                // metres
  int width = 0, height = 0;                         // nodes along x (columns) and y (rows)
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // board frame, metres; z = 0
  // The node at `point_in_board` (within `tolerance` metres in x, y and z): false if the point
  // is off the grid.
  bool Node(const Eigen::Vector3d& point_in_board, double tolerance, int* row, int* col) const;
  Eigen::Vector3d Point(int row, int col) const {
    return origin + Eigen::Vector3d(col * spacing, row * spacing, 0);
  }
};

// The coarsest regular grid with a node on every point (board frame, metres): its spacing is
// the greatest common divisor of the points' x and y offsets from the lowest x and y, to
// `tolerance` metres, and it spans exactly the points' bounding rectangle. Errors (one line):
// no points, a point off the z = 0 plane (a post tip), points that span no area, a grid of more
// than max_nodes nodes (incommensurate spacings), a point that is not within `tolerance` of
// its node.
Status FindBoardGrid(const std::vector<Eigen::Vector3d>& points, double tolerance, int max_nodes,
                     BoardGrid* grid);

}  // namespace svms
