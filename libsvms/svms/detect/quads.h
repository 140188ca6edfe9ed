// Detector step 4: quadrilaterals from segments, and their corners as line intersections.
//
// A dark square's four sides, each oriented with the dark side on its right (segments.h),
// follow one another clockwise on screen: each side ends near where the next begins, and
// turns right. Quads are the closed 4-cycles of that "follows" relation, found by a
// depth-limited search; every segment may take part in several quads, so nested and adjacent
// squares do not hide each other.
//
// Step 4b completes three-sided squares. Behind a lens's blur and a JPEG codec an 8-10 px
// square's corners round off: a side's chain then bends into its neighbour or splits below
// the segments' 4 px, and one side of four is missing from the "follows" relation (on the
// jpeg_srgb profile most of the 8-12 px markers still lost after step 7d). A chain of three
// small sides that no fourth closes is completed as a parallelogram: the missing corners lie
// along the first and third sides, the middle side's length from the known corners. Those
// corners are 1-3 px off and only good for step 8's corner fit to start from: the detector
// checks the inferred side against the middle one and refits such a quad's corners before
// reading it (detector.cc, DecodeQuad).
#pragma once

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <vector>

#include "svms/detect/segments.h"

namespace svms {

class WorkerPool;

struct Quad {
  // Corners clockwise on screen, in pixels: corner k is where side k - 1 meets side k.
  std::array<Eigen::Vector2d, 4> corners;
  std::array<int, 4> sides;  // segment indices; -1 for a side that step 4b inferred
  // Step 4b: side 3 was inferred and corners 3 and 0 are guesses, 1-3 px off.
  bool completed = false;
  double min_side() const;
  double area() const;
};

struct QuadOptions {
  double min_side = 6;          // pixels
  double join_fraction = 0.45;  // an end may be this fraction of the shorter side from the corner
  double join_min_px = 4;       // ... or this many pixels
  double min_turn_deg = 20;     // consecutive sides turn right by this much at least
  int max_quads = 2000;         // stop after this many (a safeguard on pathological images)
  // Step 4b: chains of three sides, each segment and the middle side's corner-to-corner length
  // shorter than this (pixels), that no fourth side closes are completed. 0: off.
  double complete_below_px = 12;
  // ... if their first and third sides are antiparallel within this (degrees). A small
  // square's image is near affine, its opposite sides near parallel, but the rounded corners
  // tilt the lines fitted to short sides: up to 31 degrees on the 8-12 px markers 4b gave
  // back on the small sets (jpeg_srgb, srgb8, linear). A texture's convex curve, three short
  // segments turning by a third of a circle each, is not.
  double complete_max_skew_deg = 40;
};

std::vector<Quad> FindQuads(const std::vector<Segment>& segments, const QuadOptions& options,
                            int width, int height);
// The same into *quads (replaced); with *quads kept by the caller, and this thread's scratch
// kept between calls, no allocation once they have grown. `deadline`: checked every 256
// segments; once it has passed, the quads found so far are returned and the result is false.
// `pool` (may be null): with more than one thread and at least 512 segments, the search is
// split by first side over its threads, and the quads are the same, in the same order, as on
// one thread (a deadline aside).
bool FindQuads(
    const std::vector<Segment>& segments, const QuadOptions& options, int width, int height,
    std::vector<Quad>* quads,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max(),
    WorkerPool* pool = nullptr);

// Intersection of two lines (nx, ny, c); false if they are parallel.
bool Intersect(const Eigen::Vector3d& l1, const Eigen::Vector3d& l2, Eigen::Vector2d* p);

}  // namespace svms
