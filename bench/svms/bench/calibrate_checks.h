// Cross-checks of the calibration benchmark (calibrate_benchmark.h) beyond each tool's error:
// mrcal's own comparison of each model with the truth, the SVMS board's corners against the
// true projections, and a Monte-Carlo of svms's predicted uncertainty.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "svms/bench/calibrate_tools.h"

namespace svms {

// mrcal.projection_diff of each tool's model against the true one.
struct ProjectionDiff {
  // The radius about the image centre the implied rotation was fitted within, px: the largest
  // circle holding only region cells.
  double focus_radius = 0;
  std::vector<std::array<double, 3>> rms;  // per tool: region RMS, whole-image RMS, worst (px)
};

// Runs mrcal.projection_diff through Python (files in OUT/projection_diff/); NaN for a tool
// that failed or when Python failed (the message on stderr).
ProjectionDiff RunProjectionDiff(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                                 const std::vector<ToolResult>& tools);

// The detected corners against the true projections of their board points through the views'
// true poses: what the a-posteriori noise estimates. Pixels.
struct CornerNoise {
  double rms = NAN;                   // per axis
  double mean_x = NAN, mean_y = NAN;  // the mean error
};
CornerNoise MeasureCornerNoise(const CameraModel& truth, const ToolResult& t,
                               const std::vector<ViewObservations>& views);

// svms's predicted uncertainty against a Monte-Carlo on the same geometry: the used views'
// inlier points put at their true projections plus Gaussian noise of the a-posteriori sigma,
// re-solved `trials` times.
struct MonteCarlo {
  int trials = 0, solved = 0;
  double error_rms = NAN;      // aligned error over the region and the trials, px
  double predicted_rms = NAN;  // the predictions over the same cells, px
  double seconds = 0;
  std::vector<std::string> failures;  // "trial N: why", one per trial that did not solve
};
MonteCarlo RunMonteCarlo(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                         const CalibrationOptions& calib, const ToolResult& svms,
                         const std::vector<ViewObservations>& views);

}  // namespace svms
