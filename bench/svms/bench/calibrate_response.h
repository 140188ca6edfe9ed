// The camera's response learned from the calibration board (part of `svms bench calibrate`).
//
// A camera that writes gamma-encoded files must be calibrated as well as one that writes
// linear light, and `svms calibrate --response estimate` must find its curve from the board
// itself (response_estimate.h). The check renders the calibration dataset's board views twice
// more, through the same optics with 0.7 px of defocus: once encoded with gamma 2.2 and once
// linear (its twin: same light, same noise draws before encoding). svms calibrate runs on the
// gamma views with --response estimate and on the twin with --response linear; both solutions
// are measured on the benchmark's region against the true camera like the other tools. A third
// calibration of the gamma views with the true curve declared (--response gamma:2.2) is a
// diagnostic, not a target: against the twin it shows what the encoding itself costs (8-bit
// codes spaced unevenly in light), and against the estimate's what the estimated curve's own
// error costs.
#pragma once

#include <string>

#include "svms/bench/calibrate_checks.h"
#include "svms/bench/calibrate_tools.h"
#include "svms/detect/response_estimate.h"

namespace svms {

constexpr double kCheckedGamma = 2.2;
constexpr double kCheckedDefocusPx = 0.7;

struct ResponseCheck {
  bool rendered = false;      // both boards' images are there
  bool ok = false;            // both calibrations ran
  std::string failure;        // why not
  ResponseEstimate estimate;  // from the gamma views
  // The curve refined by the board's geometry (CalibrateRunOutcome::refined_gamma; 0: not
  // refined, and why).
  double refined_gamma = 0, refined_sigma = 0;
  std::string refine_note;
  ToolResult gamma, linear;                   // the two calibrations, measured (Measure)
  CornerNoise gamma_corners, linear_corners;  // their board corners against the truth
  ToolResult known;                           // the gamma views with the true curve declared
  CornerNoise known_corners;
};

// Renders OUT/data/board_gamma2.2 and OUT/data/board_linear_defocus unless their images are
// there, calibrates both and measures them. Needs `data.cells` (the region) filled by the main
// svms and chessboard runs.
ResponseCheck RunResponseCheck(const CalibrateBenchmarkOptions& o, const CalibrationData& data);

}  // namespace svms
