// The survey pipeline of `svms survey` and `svms bench pose`: read the images, detect, survey
// the markers' layout (bundle/survey.h), write the layout and a report.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "svms/pipelines/photometry.h"

namespace svms {

// The run as the command line gives it; the texts are checked by RunSurveyFromImages and
// errors name the option.
struct SurveyRunOptions {
  std::vector<std::string> inputs;  // image files, directories or globs (image_inputs.h)
  std::string camera;               // the .cameramodel (its covariance sidecar is read too)
  std::string markers;              // the marker models (svms.markers or svms.layout)
  std::string out;                  // the layout JSON to write
  std::string report;               // "" = no report directory
  std::optional<int> reference;     // the marker whose frame is the object frame
  // With refine_intrinsics: the refined camera to write (.cameramodel and its covariance
  // sidecar, committed with the layout); "" = not written. Refused without refine_intrinsics.
  std::string out_camera;
  // "A:B:DISTANCE[:SIGMA]" and "NAME=X,Y,Z[,SIGMA]" in metres (NAME: ID, ID.tl/.tr/.br/.bl or
  // ID.tip); three control points instead of a reference fix the object frame.
  std::vector<std::string> scale_bars, control_points;
  bool refine_intrinsics = false, drop_disconnected = false, quiet = false;
  std::optional<double> corner_sigma;  // px; unset: each corner's own, from the side fits
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  PhotometryOptions photometry;
};

// Runs the survey. Returns an exit code (exit_codes.h): 2 for bad input found before any
// work, 1 when the survey failed, an output could not be written or an image could not be
// used. Messages on stderr, prefixed "svms survey: ". The report is written before the layout,
// and a report that could not be written leaves the earlier layout as it was.
int RunSurveyFromImages(const SurveyRunOptions& options);

}  // namespace svms
