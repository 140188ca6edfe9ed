// The calibration benchmark's outputs (calibrate_benchmark.h): tables, JSON, plots, report.md
// with the targets judged on this run, and a summary per tool on stdout.
#pragma once

#include <vector>

#include "svms/bench/calibrate_checks.h"
#include "svms/bench/calibrate_response.h"
#include "svms/bench/calibrate_tools.h"

namespace svms {

// What the run found, for the report.
struct CalibrateFindings {
  std::vector<ToolResult> tools;  // svms, mrcal, OpenCV
  ToolResult pass1;               // svms's first pass (corners fitted in pixels)
  ChessCorners chess;
  ProjectionDiff projection_diff;
  CornerNoise corner_noise, pass1_corner_noise;  // svms's board corners against the truth
  MonteCarlo monte_carlo;
  ResponseCheck response;  // the board through a gamma-2.2 camera and its linear twin
};

// Writes calibrate.csv, calibrate_grid.dat, calibrate.json, the plots and report.md to
// options.out, prints each tool's figures; returns the benchmark's exit code (exit_codes.h).
int WriteCalibrateReport(const CalibrateBenchmarkOptions& options, const CalibrationData& data,
                         const CalibrateFindings& findings);

}  // namespace svms
