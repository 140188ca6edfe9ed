// What is printed where: the reflectance of an object's surface pattern (checkers, stripes,
// grids, blocky text, noise) and whether a point of a marker's decal is white or black (the
// svms44 ring of the marker and of its nested inner marker, or a peer system's tag). The
// renderer looks these up analytically at each ray's hit, so an edge in the image is exactly
// where the print puts it at any resolution; the ring's bit layout is inverted once from
// MarkerModel::BitCellCentre, its one definition. The decal lookups are inline: the tracer
// calls them for every ray that meets a marker. Internal to sim (not installed).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "svms/marker/marker_model.h"
#include "svms/sim/scene.h"

namespace svms::render {

// Reflectance of material `m`'s surface pattern at surface coordinates (u, v), metres.
double PatternAt(const Material& m, double u, double v);

// True if (x, y) lies in the square of half side `half` centred on the origin (edges included).
inline bool InsideSquare(double x, double y, double half) {
  return std::abs(x) <= half && std::abs(y) <= half;
}

// The bit of each cell of the 12 x 12 grid over the ring ([row][col], row 0 at the top, col 0
// at the left, as printed), inverted once from MarkerModel::BitCellCentre, the one definition of
// the bit layout. A cell inside the ring is reached only by rounding at the ring's inner edge;
// it takes the bit of the ring cell at the left end of its row.
using RingBitTable =
    std::array<std::array<int8_t, MarkerModel::kCellsPerSide>, MarkerModel::kCellsPerSide>;
extern const RingBitTable kRingBits;

// Bit index of the ring cell containing (x, y) (inside the ring), for cell size b.
inline int CellBit(double x, double y, double b) {
  const int col = std::clamp(static_cast<int>(std::floor((x + 6 * b) / b)), 0, 11);
  const int row = std::clamp(static_cast<int>(std::floor((6 * b - y) / b)), 0, 11);
  return kRingBits[row][col];
}

// The printed pattern: true = white, at (x, y) on ring geometry (size s, cell b) with `word`.
// Returns false (and *inside = false) outside the ring.
inline bool RingWhite(double x, double y, double s, double b, uint64_t word, bool* inside) {
  const double m = std::max(std::abs(x), std::abs(y));
  *inside = m <= 6 * b;
  if (m <= 0.5 * s) return false;
  if (m <= 5 * b) return true;
  return (word >> CellBit(x, y, b)) & 1;
}

// A peer tag (PrintedTag) on a marker of black-square side s and decal half side `half`: its
// n x n grid fills the black square, white around it. Returns false (and *inside = false)
// outside the decal.
inline bool PeerWhite(double x, double y, double s, double half, const PrintedTag& t,
                      bool* inside) {
  const double m = std::max(std::abs(x), std::abs(y));
  *inside = m <= half;
  if (m > 0.5 * s) return true;
  const int col = std::clamp(static_cast<int>(std::floor((x + 0.5 * s) / s * t.n)), 0, t.n - 1);
  const int row = std::clamp(static_cast<int>(std::floor((0.5 * s - y) / s * t.n)), 0, t.n - 1);
  return t.white[static_cast<size_t>(row) * t.n + col];
}

}  // namespace svms::render
