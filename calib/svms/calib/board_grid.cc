#include "svms/calib/board_grid.h"

#include <algorithm>
#include <cmath>

#include "svms/base/format.h"

namespace svms {
namespace {

// The greatest common divisor of two non-negative lengths, to `tol`: Euclid's algorithm with
// remainders within tol of zero or of the divisor taken as zero.
double Gcd(double a, double b, double tol) {
  if (a < b) std::swap(a, b);
  while (b > tol) {
    double r = std::fmod(a, b);
    if (b - r <= tol) r = 0;
    a = b, b = r;
  }
  return a;
}

}  // namespace

bool BoardGrid::Node(const Eigen::Vector3d& p, double tol, int* row, int* col) const {
  if (!(spacing > 0)) return false;
  const double x = (p.x() - origin.x()) / spacing, y = (p.y() - origin.y()) / spacing;
  const long j = std::lround(x), i = std::lround(y);
  if (i < 0 || j < 0 || i >= height || j >= width) return false;
  if ((Point(static_cast<int>(i), static_cast<int>(j)) - p).cwiseAbs().maxCoeff() > tol)
    return false;
  *row = static_cast<int>(i), *col = static_cast<int>(j);
  return true;
}

Status FindBoardGrid(const std::vector<Eigen::Vector3d>& points, double tol, int max_nodes,
                     BoardGrid* grid) {
  if (points.empty()) return Status::Error("no board points");
  Eigen::Vector3d lo = points[0], hi = points[0];
  for (const Eigen::Vector3d& p : points) {
    if (!(std::abs(p.z()) <= tol))
      return Status::Error("a point is off the board's plane (z = " + Significant(p.z(), 9) +
                           " m: a post tip); mrcal's calibration object is flat");
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  if (!(hi.x() - lo.x() > tol && hi.y() - lo.y() > tol))
    return Status::Error("the points span no area");
  double g = 0;
  for (const Eigen::Vector3d& p : points)
    for (const double v : {p.x() - lo.x(), p.y() - lo.y()})
      if (v > tol) g = g == 0 ? v : Gcd(g, v, tol);
  // Nodes across: the extent over the spacing; the spacing is then taken as extent / steps, so
  // that the grid ends exactly on the outermost points.
  const double wx = (hi.x() - lo.x()) / g, wy = (hi.y() - lo.y()) / g;
  if (!(wx + 1 <= max_nodes && wy + 1 <= max_nodes && (wx + 1) * (wy + 1) <= max_nodes))
    return Status::Error("the points lie on no regular grid of at most " +
                         std::to_string(max_nodes) + " nodes (common spacing " + Significant(g, 9) +
                         " m for a " + Significant(hi.x() - lo.x(), 9) + " x " +
                         Significant(hi.y() - lo.y(), 9) + " m board)");
  BoardGrid r;
  r.width = static_cast<int>(std::lround(wx)) + 1;
  r.height = static_cast<int>(std::lround(wy)) + 1;
  r.spacing = (hi.x() - lo.x()) / (r.width - 1);
  r.origin = Eigen::Vector3d(lo.x(), lo.y(), 0);
  if (std::abs((r.height - 1) * r.spacing - (hi.y() - lo.y())) > tol)
    return Status::Error("the points lie on no grid with one spacing in x and y");
  int i, j;
  for (const Eigen::Vector3d& p : points)
    if (!r.Node(p, tol, &i, &j))
      return Status::Error("the point (" + Significant(p.x(), 9) + ", " + Significant(p.y(), 9) +
                           ") m is not on the grid of spacing " + Significant(r.spacing, 9) + " m");
  *grid = r;
  return Status::Ok();
}

}  // namespace svms
