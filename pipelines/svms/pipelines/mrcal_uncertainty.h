// The uncertainty of a camera calibrated by mrcal's own tools, as SVMS's covariance sidecar.
//
// mrcal 2.2 keeps a model's uncertainty as its whole calibration problem ('optimization_inputs'
// in the .cameramodel, a Python literal with binary arrays), which only its Python evaluates; its
// C library neither reads it nor exposes the packed state's scaling. So this runs mrcal's Python
// once (no shell: run_program.h) and writes CAM.cameramodel.covariance.json
// (svms/camera/camera_covariance.h), which every consumer (svms detect, pose, survey, the C API,
// the Python package) then reads without Python. The covariance is computed as
// mrcal.projection_uncertainty computes it: mrcal.optimizer_callback(**optimization_inputs)
// gives J at the optimum and the factorisation of J*^T J* (packed state b = D b*); with sigma the
// input noise (mrcal's observed_pixel_uncertainty: the standard deviation of the boards'
// residuals unless given),
//   Cov(S b) = sigma^2 S D inv(J*^T J*) J*obs^T J*obs inv(J*^T J*) D S^T,
// J*obs the boards' rows (the regularisation's rows are not noise), S the rows that pick the
// intrinsics of the model's camera and the rigid motion [psi, kappa] of the mean board frame
// (mrcal's mean-frames construction in _projection_uncertainty, differentiated once).
#pragma once

#include <Eigen/Core>
#include <string>

#include "svms/base/status.h"
#include "svms/camera/camera.h"

namespace svms {

struct MrcalUncertaintyOptions {
  std::string camera;                       // the .cameramodel with optimization_inputs
  std::string python = "/usr/bin/python3";  // a Python with numpy and mrcal 2.2
  // The corner noise (pixels, > 0); 0: from the residuals at the optimum, as mrcal does.
  double observed_pixel_uncertainty = 0;
};

struct MrcalUncertaintyResult {
  CameraModel camera;  // the model as CameraModel::Read reads it, with the intrinsics factor set
  Eigen::MatrixXd mean_frames_factor;  // (N + 6) x (N + 6), camera_covariance.h
  double noise_sigma_px = 0;           // the sigma used (pixels)
  int views = 0;                       // board observations of the calibration
  std::string sidecar;  // the path written; set (with an error) also when only the write failed
};

// Computes the covariance with mrcal's Python and writes the sidecar next to the model
// (atomically; the model is not touched). Errors are one line and start with the model's path:
// a model SVMS cannot read or measure with, a model without optimization_inputs (checked before
// Python starts), no Python or no mrcal there (exit 127 or an ImportError: says which), mrcal
// failing on the problem (its last line of stderr), a result for another model (lens model, size
// or intrinsics that differ from the file's), a failed write.
Status ImportMrcalUncertainty(const MrcalUncertaintyOptions& options,
                              MrcalUncertaintyResult* result);

// For the commands that measure with a camera: when the model at `camera_path` has mrcal's
// optimization_inputs but no covariance sidecar, one line (no newline) saying how to make it:
// "CAM has mrcal's optimization_inputs but no CAM.covariance.json: `svms camera
// import-uncertainty CAM` writes it". "" otherwise (a sidecar there, no optimization_inputs,
// an unreadable file).
std::string MissingUncertaintyHint(const std::string& camera_path);

}  // namespace svms
