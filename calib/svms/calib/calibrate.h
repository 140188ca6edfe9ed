// Camera intrinsic calibration from views of a known calibration object (a Layout: a board from
// board.h or any surveyed layout). Without user input: the focal length is seeded from the
// views' homographies (Zhang's method, OpenCV's initCameraMatrix2D, principal point at the image
// centre), each board pose by IPPE (cv::solvePnP), then Ceres optimises the intrinsics, every
// board pose and optionally the board's warp (mrcal's two-parameter flatness deviation):
//   1. the core (fx, fy, cx, cy) only, distortion held at zero, Huber loss;
//   2. every parameter, Huber loss;
//   3. outlier rejection (points whose residual exceeds outlier_threshold times the residuals'
//      standard deviation) and re-solve, until the outlier set stops changing;
//   4. a final plain least-squares solve on the inliers (so the covariance below is that of
//      the least-squares optimum).
// The residuals are mrcal_project's (projection_cost.h), with its analytic gradients. Splined
// models get mrcal-style regularisation (a weak prior pulling the control points to zero and
// the centre to the image centre). The parameter covariance is mrcal's:
//   Var(b) = sigma^2 inv(JtJ) J_obs^t J_obs inv(JtJ),
// sigma the a-posteriori noise of the inlier residuals (mrcal's observed_pixel_uncertainty,
// estimated from the residuals of the fit, not assumed).
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "svms/base/status.h"
#include "svms/calib/observations.h"
#include "svms/calib/projection_cost.h"
#include "svms/camera/camera.h"
#include "svms/geometry/pose.h"

namespace svms {

struct CalibrationOptions {
  // An mrcal lens model: LENSMODEL_PINHOLE, LENSMODEL_OPENCV4/5/8/12, LENSMODEL_STEREOGRAPHIC,
  // LENSMODEL_SPLINED_STEREOGRAPHIC_order=..._Nx=..._Ny=..._fov_x_deg=... or the bare
  // LENSMODEL_SPLINED_STEREOGRAPHIC (then order 3, Nx 16, Ny from the aspect ratio, and a
  // field of view 1.3 times the seed's).
  std::string lensmodel = "LENSMODEL_OPENCV8";
  int width = 0, height = 0;  // the images' size, pixels
  bool board_warp = false;    // also estimate the board's flatness deviation (two numbers)
  // Also estimate one edge bias (pixels): every marker side seen that far out of its black
  // square (EdgeBiasedProjectionCost), whatever the view. A response curve a little off (an
  // estimated gamma's own error, a camera's tone curve not quite sRGB) makes a blurred edge's
  // linearised profile lopsided, and the side's fitted line moves toward the dark or the
  // bright side by a share of the blur, on every marker alike where the blur is alike (one b
  // is the average where it varies from view to view). The board's geometry tells
  // that apart from the lens (the markers' sizes against their spacing), so the lens model
  // does not take it up. Costs one parameter; worth it where the response is not known.
  bool edge_bias = false;
  double huber_px = 1.0;           // Huber loss scale during stages 1-3 (pixels)
  double outlier_threshold = 4.0;  // in standard deviations of the inlier residuals (each axis)
  double min_outlier_px = 0.2;     // never call a point with |residual| below this an outlier
  int max_outlier_rounds = 8;
  int min_views = 3;             // usable views needed
  int min_points_per_view = 12;  // planar points a view needs to be used (3 markers' corners)
  double max_rms_px = 2.0;       // a larger final RMS means the board does not match the images
  double min_tilt_deg = 8;       // some view must be tilted this much, or f is not observable
  // For models with distortion: the observed corners must reach this fraction of the half
  // diagonal from the image centre, or the distortion is not observable.
  double min_reach = 0.45;
  double max_focal_rel_sigma = 0.02;  // larger predicted sigma(fx)/fx: the views do not constrain f
  int max_iterations = 200;           // per solve
  double spline_prior_weight = 0.01;  // regularisation of splined models (per pixel of effect)
  int threads = 1;
  bool verbose = false;  // stage-by-stage progress on stderr
  Status Check() const;
};

// Checks what can be checked before any image is read, so that a command refuses a bad
// request at once (exit 2) instead of after detecting every image: the lens model's name (a
// known mrcal model with gradients, or the bare LENSMODEL_SPLINED_STEREOGRAPHIC), and that the
// covariance of `num_views` views fits in memory (memory_limit.h: about 12 dense matrices of
// (intrinsics + 6 x views)^2 doubles, and the eigen-decomposition's time grows as its cube).
Status CheckCalibrationRequest(const std::string& lensmodel, int num_views);

// What to add to the message of a solve that did not converge, given its lens model and its
// last intrinsics (mrcal's order): for LENSMODEL_OPENCV8 and OPENCV12 with both k1 and k4
// beyond 10 in magnitude, a sentence naming the valley of their rational distortion, where
// numerator and denominator grow together and the projection hardly changes (with k1..k3 and
// k4..k6 growing alike the ratio tends to a finite function; docs/conventions.md measures how
// far calibrations wander along it). Otherwise "".
std::string RationalDistortionValleyHint(const std::string& lensmodel,
                                         const std::vector<double>& intrinsics);

struct CalibrationResult {
  CameraModel camera;
  std::vector<int> views;  // indices (into the input) of the views used, in order
  std::vector<std::pair<int, std::string>> skipped;  // views not used, and why
  std::vector<Pose> cam_from_board;                  // per used view
  Eigen::Vector2d warp = Eigen::Vector2d::Zero();    // metres (zero without board_warp)
  // With edge_bias: the fitted edge bias and its standard deviation, pixels (> 0: the sides
  // are seen outside the black square's true edge). Zero without.
  double edge_bias_px = 0, edge_bias_sigma_px = 0;
  BoardExtent extent;
  // Per used view and point (same order as the input's points): predicted - observed (pixels,
  // unweighted; the prediction includes the edge bias) and whether the point was rejected as
  // an outlier.
  std::vector<std::vector<Eigen::Vector2d>> residuals;
  std::vector<std::vector<bool>> outlier;
  double rms_px = 0;    // RMS of |residual| over the inliers (2-D norm)
  double worst_px = 0;  // largest inlier |residual|
  double sigma_px = 0;  // standard deviation of the inlier residual coordinates
  int num_inliers = 0, num_outliers = 0;
  int outlier_rounds = 0;
  int iterations = 0;  // Ceres iterations over all solves
  // Covariance of the state [intrinsics (N), cam_from_board per used view (6 each: rotation
  // vector, translation), warp (2, with board_warp), edge bias (1, with edge_bias)]; units of
  // the parameters. Also as a factor
  // F with covariance = F F^t (what ProjectionCovariance uses: positive semi-definite by
  // construction, where the dense matrix of a nearly degenerate model loses that to round-off).
  Eigen::MatrixXd covariance;
  Eigen::MatrixXd covariance_factor;
  // The a-posteriori corner noise the covariance is scaled by: the RMS of the weighted inlier
  // residual coordinates over their degrees of freedom (2 per inlier less the state's
  // dimension), pixels (mrcal's observed_pixel_uncertainty).
  double noise_sigma_px = 0;
  // The sigma whose residuals have weight 1 (the first used point's sigma_px): every residual
  // is weighted by reference_sigma_px / its point's sigma_px, pixels.
  double reference_sigma_px = 0;
  std::string report;  // the final Ceres solve's one-line report
};

// Calibrates from `views` (each a ViewObservations of one image). Views with fewer than
// min_points_per_view points on the z = 0 plane of the object are skipped (listed in
// result->skipped). Errors (one line, no model): too few usable views; views that cannot
// constrain the model (all fronto-parallel, all corners near the image centre, a focal length
// left undetermined); a solve that does not converge; an RMS above max_rms_px (the object does
// not match the images). On error, *result holds what was computed so far.
Status Calibrate(const std::vector<ViewObservations>& views, const CalibrationOptions& options,
                 CalibrationResult* result);

// The lens model a calibration solves for: `lensmodel` itself, except the bare
// "LENSMODEL_SPLINED_STEREOGRAPHIC", which becomes order 3, Nx 16, Ny = 16 * height / width
// (at least 4) and fov_x_deg 1.3 times the field of view of a pinhole of focal length
// `focal_px` (rounded up to whole degrees).
std::string ResolveLensModel(const std::string& lensmodel, int width, int height, double focal_px);

// The covariance (pixels^2) of the projection of the point seen at pixel `px` at `range` metres
// from the camera, propagated from the input noise through the optimum as mrcal does: the
// point is fixed in every board's frame, mapped back through the perturbed board poses, their
// mean taken as the camera-frame point, and projected with the perturbed intrinsics. False if
// the pixel does not unproject.
bool ProjectionCovariance(const CalibrationResult& result, const Eigen::Vector2d& px, double range,
                          Eigen::Matrix2d* covariance);

// The projection error of a calibrated camera against a known true one, in the sense the
// projection covariance predicts: the pixel `px` of the true camera is unprojected to `range`
// metres, carried into every board's frame by its true pose, back into the calibrated camera
// by the solved poses (mean over the boards: this removes the arbitrary rotation a calibration
// cannot tell from a shift of the principal point), and projected with the solved
// intrinsics. Returns calibrated - true pixel; false if a projection fails.
// true_cam_from_board: one per used view, in result.views order.
bool AlignedProjectionError(const CalibrationResult& result, const CameraModel& true_camera,
                            const std::vector<Pose>& true_cam_from_board, const Eigen::Vector2d& px,
                            double range, Eigen::Vector2d* error);

}  // namespace svms
