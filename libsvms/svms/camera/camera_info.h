// What `svms camera show` says about a camera model file: the lens model and image size, the
// field of view, how far the distortion moves pixels, and what uncertainty comes with it.
//
// A model's uncertainty can come from two places, and neither is in the core keys the C API
// reads: SVMS's own sidecar (CAMERA.cameramodel.covariance.json, camera_covariance.h), which
// svms pose uses, and mrcal's 'optimization_inputs' (the whole calibration problem, written by
// mrcal-calibrate-cameras), which only mrcal's Python tools evaluate
// (mrcal.projection_uncertainty). Both are reported.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"

namespace svms {

struct CameraInfo {
  CameraModel camera;
  // The angle (degrees) between the rays through the left and right edges of the image
  // (u = -0.5 and u = width - 0.5, on the middle row), and between the top and bottom edges
  // (middle column). NaN where a ray cannot be found (mrcal 2.2 cannot unproject CAHVORE).
  double fov_x_deg = 0, fov_y_deg = 0;
  // The distortion's names and values for the OpenCV models (k1 k2 p1 p2 k3 k4 k5 k6 s1..s4),
  // else empty: distortion_count says how many parameters follow fx, fy, cx, cy.
  std::vector<std::pair<std::string, double>> distortion;
  int distortion_count = 0;
  // The largest distance (pixels) over a 17 x 17 grid of pixels spanning the image between a
  // pixel and the projection of its ray through the model's pinhole core (fx, fy, cx, cy):
  // how far the distortion moves a point. 0 for LENSMODEL_PINHOLE; NaN when not computable.
  double max_distortion_px = 0;
  // The covariance sidecar: its path when it exists, and "" when it matches the model, else
  // why it cannot be used (a stale sidecar of another calibration, a bad file).
  std::string sidecar_path;
  std::string sidecar_error;
  // The model file carries mrcal's 'optimization_inputs'.
  bool has_optimization_inputs = false;
};

// Reads the model at `path` (CameraModel::Read: any lens model, usable or not) and describes
// it. Errors are CameraModel::Read's; a bad sidecar is reported in sidecar_error, not as an
// error, so that a stale sidecar can be seen.
Status ReadCameraInfo(const std::string& path, CameraInfo* out);

// Whether the text of an mrcal .cameramodel has the key 'optimization_inputs' (outside
// comments).
bool HasOptimizationInputs(const std::string& cameramodel_text);

}  // namespace svms
