// The sides of a quadrilateral seen in an image: corners in pixels, in either winding.
#pragma once

#include <Eigen/Core>
#include <array>

namespace svms {

// The mean of a quad's four corners (pixels).
inline Eigen::Vector2d QuadCentroid(const std::array<Eigen::Vector2d, 4>& corners) {
  return 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
}

// The unit normal of the side from `a` to `b` (pixels) that points away from `centre`, a point
// inside the quad (its centroid): the side's outward normal whichever way the quad winds, for
// a convex quad. Zero when a == b. When `centre` lies on the side's line (a degenerate quad) the
// normal is (-d.y, d.x) / |d|, d = b - a: to the right of a -> b as an image is shown (y down).
inline Eigen::Vector2d OutwardNormal(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                     const Eigen::Vector2d& centre) {
  const Eigen::Vector2d d = b - a;
  const double length = d.norm();
  if (!(length > 0)) return Eigen::Vector2d::Zero();
  Eigen::Vector2d n(-d.y() / length, d.x() / length);
  if (n.dot(0.5 * (a + b) - centre) < 0) n = -n;
  return n;
}

// OutwardNormal of side k, from corner k to corner k + 1 (mod 4), about the quad's centroid.
inline std::array<Eigen::Vector2d, 4> QuadOutwardNormals(
    const std::array<Eigen::Vector2d, 4>& corners) {
  const Eigen::Vector2d centre = QuadCentroid(corners);
  std::array<Eigen::Vector2d, 4> normal;
  for (int k = 0; k < 4; ++k) normal[k] = OutwardNormal(corners[k], corners[(k + 1) % 4], centre);
  return normal;
}

}  // namespace svms
