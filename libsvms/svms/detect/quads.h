// Detector step 4: quadrilaterals from segments, and their corners as line intersections.
//
// A dark square's four sides, each oriented with the dark side on its right (segments.h),
// follow one another clockwise on screen: each side ends near where the next begins, and
// turns right. Quads are the closed 4-cycles of that "follows" relation, found by a
// depth-limited search; every segment may take part in several quads, so nested and adjacent
// squares do not hide each other.
#pragma once

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <vector>

#include "svms/detect/segments.h"

namespace svms {

struct Quad {
  // Corners clockwise on screen, in pixels: corner k is where side k - 1 meets side k.
  std::array<Eigen::Vector2d, 4> corners;
  std::array<int, 4> sides;  // segment indices
  double min_side() const;
  double area() const;
};

struct QuadOptions {
  double min_side = 6;          // pixels
  double join_fraction = 0.45;  // an end may be this fraction of the shorter side from the corner
  double join_min_px = 4;       // ... or this many pixels
  double min_turn_deg = 20;     // consecutive sides turn right by this much at least
  int max_quads = 2000;         // stop after this many (a safeguard on pathological images)
};

std::vector<Quad> FindQuads(const std::vector<Segment>& segments, const QuadOptions& options,
                            int width, int height);
// The same into *quads (replaced); with *quads kept by the caller, and this thread's scratch
// kept between calls, no allocation once they have grown. `deadline`: checked every 256
// segments; once it has passed, the quads found so far are returned and the result is false.
bool FindQuads(
    const std::vector<Segment>& segments, const QuadOptions& options, int width, int height,
    std::vector<Quad>* quads,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

// Intersection of two lines (nx, ny, c); false if they are parallel.
bool Intersect(const Eigen::Vector3d& l1, const Eigen::Vector3d& l2, Eigen::Vector2d* p);

}  // namespace svms
