// The physical description of one SVMS marker: what the detector, the simulator, the pose
// solver and the artwork all read. Metres; marker frame as in docs/conventions.md (origin at
// the centre of the black square on the base plane, x right and y up as printed, z out of the
// surface toward the viewer).
//
// Geometry, from the centre out: the black square (side `size`, the pose reference), the
// white stripe (`stripe_width`), then a ring of 12 x 12 square bit cells minus the inner
// 10 x 10 (44 cells of side `cell_size`; 11 per side, clockwise from the top-left corner). The
// stripe fills the space between square and ring, so size / 2 + stripe_width = 5 * cell_size.
// A post stands at the centre (or a concave well is sunk there). A dual marker nests a smaller
// marker inside the black square; the post is shared by both.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

#include "svms/base/status.h"

namespace svms {

struct PostModel {
  // > 0: a protruding post with a white top at z = height; < 0: a concave well with a white
  // bottom at z = height. Metres, never 0.
  double height = 0;
  double radius = 0;      // of the post's cylinder (or the well's bore), metres
  double tip_radius = 0;  // of the white disc on top (or at the bottom), metres, <= radius
  bool concave() const { return height < 0; }
};

// A marker nested inside the black square of another (the dual marker's inner marker).
struct NestedMarker {
  int id = -1;
  double size = 0;
  double stripe_width = 0;
  double cell_size = 0;
};

struct MarkerModel {
  static constexpr int kCellsPerSide = 12;  // cells across the ring's outer edge
  std::string family = "svms44";
  int id = -1;
  double size = 0;          // side of the black square, metres
  double stripe_width = 0;  // metres
  double cell_size = 0;     // side of a bit cell, metres
  std::optional<PostModel> post;
  std::optional<NestedMarker> inner;

  // The standard proportions: cell = size / 6, stripe = 2 cells, post height size / 4
  // (radius size / 20) unless `post_height` is 0 (no post); negative for a concave well.
  static MarkerModel Standard(int id, double size, double post_height);
  // Adds a nested marker of the standard proportions.
  void AddInner(int inner_id, double inner_size);

  // Half the side of the whole marker (the outer edge of the bit ring): 6 cells.
  double half_extent() const { return 0.5 * kCellsPerSide * cell_size; }
  // Black-square corners in the marker frame (z = 0): top-left, top-right, bottom-right,
  // bottom-left as printed.
  std::array<Eigen::Vector3d, 4> Corners() const;
  // The post tip (centre of the white top, or of the well's white bottom), or nullopt.
  std::optional<Eigen::Vector3d> PostTip() const;
  // Centre of bit cell i in the marker plane (metres), i in [0, 44).
  Eigen::Vector2d BitCellCentre(int i) const;
  // The inner marker as a marker of its own (same centre, the shared post), or nullopt.
  std::optional<MarkerModel> InnerModel() const;

  // Checks every field and the geometric constraints; the message names the field (prefixed
  // with `path`, e.g. "markers[2].") and what was expected.
  Status Validate(const std::string& path = "") const;
  // One-line summary: "dual marker 17/5 (svms44), 0.432/0.108 m, post +0.108 m".
  std::string Summary() const;
};

}  // namespace svms
