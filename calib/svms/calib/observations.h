// What a calibration sees: for each image, the pixels of known points of the calibration
// object (a Layout, e.g. a board from board.h), matched by marker ID.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "svms/detect/detector.h"
#include "svms/marker/layout.h"

namespace svms {

// One observed point of the calibration object.
struct PointObservation {
  Eigen::Vector3d point_in_board;  // metres, the layout's (object) frame
  Eigen::Vector2d pixel;           // where it was seen; pixels (docs/conventions.md)
  double sigma_px = 0.1;           // standard deviation of the pixel, each axis
  int marker_id = -1;              // the detected marker (outer or inner ID)
  int corner = 0;                  // 0..3 = TL TR BR BL as printed; kTip = the post tip
  // How the pixel moves when each side of its black square is seen 1 px further out (into the
  // white stripe), pixels per pixel: the corner where two such lines meet moves by
  // (n1 + n2) / (1 + n1.n2), n1 and n2 the sides' outward unit normals in the image (about
  // sqrt(2) along the diagonal for a square seen head on). Zero for the post tip. What the
  // calibration's edge bias (CalibrationOptions::edge_bias) multiplies.
  Eigen::Vector2d edge_shift = Eigen::Vector2d::Zero();
  static constexpr int kTip = 4;
};

// Everything seen in one image.
struct ViewObservations {
  std::string name;  // the image, for messages and the report
  std::vector<PointObservation> points;
  int markers = 0;               // detections matched to the layout
  std::vector<int> unknown_ids;  // detected IDs that are not in the layout
};

// Matches detections to the layout by ID: the four corners of every matched marker (its own
// corners for the inner marker of a dual), and the post tip when the detection has one and the
// layout's marker has a post. Corners get `corner_sigma_px` and their edge_shift (from the
// detected quad), tips their own TipObservation sigma. Detections of IDs not in the layout go to
// unknown_ids.
ViewObservations ObservationsFromDetections(const std::vector<Detection>& detections,
                                            const Layout& layout, const std::string& name,
                                            double corner_sigma_px);

// The edge_shift of each corner of a quad (pixels, TL TR BR BL in the image, either winding):
// see PointObservation::edge_shift. Zero for a corner whose two sides are (nearly) parallel
// or degenerate.
std::array<Eigen::Vector2d, 4> QuadEdgeShifts(const std::array<Eigen::Vector2d, 4>& corners);

}  // namespace svms
