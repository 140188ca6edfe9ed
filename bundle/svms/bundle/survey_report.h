// The survey's report for people: per-marker position and orientation sigmas, residuals per
// image and per marker, the rejected points, and a picture of the layout (markers, their
// uncertainty ellipsoids magnified, and the camera positions) drawn with gnuplot.
#pragma once

#include <functional>
#include <string>

#include "svms/base/file_io.h"
#include "svms/base/status.h"
#include "svms/bundle/survey.h"

namespace svms {

// Per-marker figures derived from the layout's covariances.
struct MarkerSigmas {
  int id = -1;
  double position_mm = 0;      // sqrt(trace) of the translation block, millimetres
  double orientation_deg = 0;  // sqrt(trace) of the rotation block, degrees
  double post_height_mm = -1;  // post height sigma, millimetres; -1 without a post
};
std::vector<MarkerSigmas> ComputeMarkerSigmas(const Layout& layout);

// Draws dir/NAME.png (and .svg) from a gnuplot `body` (everything but the terminal and output
// lines) at `size` ("width,height" pixels), adding the files to `files` (committed with the
// rest of the report). The library does not start programs: the caller passes its plotter
// (the svms command's runs gnuplot).
using PlotFunction =
    std::function<Status(const std::string& dir, const std::string& name, const std::string& body,
                         const std::string& size, AtomicFileSet* files)>;

// Writes into `dir` (created): report.md, markers.csv, images.csv, rejected.csv, and through
// `plot` (may be empty: no pictures) layout.png/.svg and residuals.png/.svg; a picture that
// fails is noted in report.md. The files are written as one group (AtomicFileSet): on an
// error none replaces a file of an earlier report. Errors name the file that could not be
// written.
Status WriteSurveyReport(const SurveyResult& result, const std::string& dir,
                         const PlotFunction& plot);

}  // namespace svms
