// The survey's report for people: per-marker position and orientation sigmas, residuals per
// image and per marker, the rejected points, and a picture of the layout (markers, their
// uncertainty ellipsoids magnified, and the camera positions) drawn with gnuplot.
#pragma once

#include <string>

#include "svms/status.h"
#include "svms/survey.h"

namespace svms::bundle {

// Per-marker figures derived from the layout's covariances.
struct MarkerSigmas {
  int id = -1;
  double position_mm = 0;      // sqrt(trace) of the translation block, millimetres
  double orientation_deg = 0;  // sqrt(trace) of the rotation block, degrees
  double post_height_mm = -1;  // post height sigma, millimetres; -1 without a post
};
std::vector<MarkerSigmas> ComputeMarkerSigmas(const Layout& layout);

// Writes into `dir` (created): report.md, markers.csv, images.csv, rejected.csv,
// layout.png/.svg (gnuplot; the picture is skipped with a note in report.md when gnuplot is
// not installed) and residuals.png/.svg. Errors name the file that could not be written.
Status WriteSurveyReport(const SurveyResult& result, const std::string& dir);

// Runs gnuplot on `script` (written to dir/name.gp); false if gnuplot is missing or fails.
bool RunGnuplot(const std::string& dir, const std::string& name, const std::string& script);

}  // namespace svms::bundle
