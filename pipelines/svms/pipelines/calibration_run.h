// The calibration pipeline of `svms calibrate` and `svms bench calibrate`: detect the board's
// markers in every image, calibrate (calib/calibrate.h), write the model and a report.
#pragma once

#include <string>
#include <vector>

#include "svms/calib/calibrate.h"
#include "svms/detect/response_estimate.h"
#include "svms/marker/layout.h"
#include "svms/pipelines/photometry.h"

namespace svms {

struct CalibrateRunOptions {
  std::vector<std::string> images;  // image files (already expanded)
  std::string board;                // the layout JSON (for messages; `layout` is what is used)
  Layout layout;
  CalibrationOptions calib;      // width/height are filled from the images
  std::string out;               // the .cameramodel to write ("" = none)
  std::string report_dir;        // "" = no report
  double uncertainty_range = 0;  // metres; 0 = the median board distance
  int threads = 1;
  bool quiet = false;
  // Detect again with the first pass's lens model (corners fitted in the undistorted plane, so
  // the curved image of a marker's side does not bias them) and calibrate again.
  bool redetect = true;
  PhotometryOptions photometry;  // how the images become linear light (photometry.h)
  // Whether the calibration also fits an edge bias (CalibrationOptions::edge_bias; its
  // calib.edge_bias is set from this): kAuto fits it when the response is estimated, whose
  // own error it takes up; a response declared is trusted.
  enum class EdgeBias { kAuto, kOn, kOff } edge_bias = EdgeBias::kAuto;
  // Also store the calibration in the model as mrcal's optimization_inputs, written by this
  // Python (mrcal_optimization_inputs.h); when it cannot be, the model is written without them.
  bool mrcal_inputs = true;
  std::string python = "/usr/bin/python3";
};

struct CalibrateRunOutcome {
  CalibrationResult result;
  ResponseEstimate response;  // with --response estimate: the camera's response from the edges
  // With --response estimate and the edge bias fitted: the curve the board's geometry gives
  // (RefineGammaFromEdgeBias in calibration_run.cc), what the camera's photometric file then
  // stores; 0 when not refined, and then refine_note says why ("" when no edge bias was
  // fitted: a declared response, or --edge-bias off).
  double refined_gamma = 0, refined_gamma_sigma = 0;
  double edge_bias_per_gamma = 0;  // px per unit of gamma, measured on these images
  std::string refine_note;
  std::vector<std::string> image_of_view;  // per input view (readable images), its file
  std::vector<ViewObservations> views;     // per input view, what was seen (result.views
                                           // indexes into it)
  std::vector<std::string> errors;         // per-image problems (unreadable, wrong size, ...)
  double uncertainty_range = 0;            // the range used, metres
  double uncertainty_rms = 0, uncertainty_max = 0;  // sqrt(trace) over the image grid, px
  double coverage = 0;                              // fraction of 16x16 image cells with an inlier
  // Whether the model carries mrcal's optimization_inputs, and if not, why (one line).
  bool has_optimization_inputs = false;
  std::string optimization_inputs_note;
  CalibrationResult pass1;  // with redetect: the first pass (corners fitted in pixels)
  std::vector<ViewObservations> pass1_views;  // and what it saw
};

// Runs the pipeline. Returns an exit code (exit_codes.h); messages on stderr, one line each,
// prefixed "svms calibrate: ". The model, its covariance sidecar (and photometric file) and
// the report are written as one group: all of them or none.
int RunCalibration(const CalibrateRunOptions& options, CalibrateRunOutcome* outcome);

}  // namespace svms
