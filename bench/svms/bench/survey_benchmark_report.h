// The survey benchmark's outputs (survey_benchmark.h): tables, plots and report.md with the
// targets judged on this run.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/bench/survey_benchmark.h"
#include "svms/bench/survey_errors.h"

namespace svms {

// One timed survey of a synthetic object.
struct SurveyTiming {
  std::string name, covariance_algorithm;
  int images = 0, markers = 0, detections = 0;
  double init = 0, solve = 0, covariance = 0, total = 0;  // seconds
  bool ok = false;
};

// What the run measured.
struct SurveyFindings {
  // The rendered mockup: its detections and the survey of them.
  std::vector<SurveyImage> images;
  std::map<int, int> detections_of;  // per marker ID
  double detect_s = 0, solve_s = 0;
  int ref = -1;           // the reference marker
  SurveyOptions options;  // the survey's options
  Status solved;          // the survey's outcome
  SurveyResult result;
  std::vector<MarkerError> ba, init, naive;    // the survey, its initialisation, the baseline
  std::vector<double> nees_without_repeat;     // NEES without the repeated corner error term
  std::map<int, std::vector<double>> outward;  // corner errors along the outward diagonal
  // The Monte-Carlo, per marker ID.
  int runs = 0, mc_failed = 0;
  double lo = 0, hi = 0;  // chi-square 95 % bounds on the mean NEES of the runs
  std::map<int, std::vector<double>> nees, mc_pos_ba, mc_pos_naive, mc_ang_ba, mc_ang_naive;
  std::vector<SurveyTiming> timings;
};

// Writes markers.csv, errors.dat, the plots and report.md (also on stdout); returns the
// benchmark's exit code (exit_codes.h). The per-marker maps of *findings are read with
// operator[]: a marker surveyed but missing from one gets an empty entry, shown in the tables.
int WriteSurveyBenchmarkReport(const SurveyBenchmarkOptions& options, SurveyFindings* findings);

}  // namespace svms
