// The survey of a camera rig's extrinsics: where each camera sits on the rig (rig_from_cam),
// from frames of an object whose layout is already surveyed, taken by the rig's cameras at
// common time stamps.
//
// Unknowns: rig_from_cam of every camera but the reference, and rig_from_object of every time
// step that some camera saw. The gauge: the reference camera's rig_from_cam is held at the
// value given, so the rig frame stays the one the rig file's writer chose (tied to that
// camera); the others are measured relative to it.
//
// Measurements: the fused pose's corners and tips (object_pose.h; not its stripe and decal
// edges), one Ceres residual per corner and post tip of every marker seen, with the fused pose's
// pixel sigmas (CornerPixelSigma, TipPixelSigma) and the survey's projection cost
// (RigMarkerPointCost around MarkerPointCost, cost_functions.h). The layout, the post heights and
// the intrinsics are constant blocks. Corners are independent points, with the sigmas the fusion
// gives independent corners: ObjectPoseOptions::corner_covariance_from_fit (the fusion's joint 8x8
// whitening, off by default) is not applied here.
//
// Steps (SurveyRig):
//   1. Each camera's own fused pose at every time step (SolveObjectPose).
//   2. Start: the cameras reached from the reference through time steps seen by both, each
//      rig_from_cam_k = rig_from_cam_j cam_j_from_object inverse(cam_k_from_object) averaged
//      robustly over those time steps (RobustAverage, view_graph.h); each time step's
//      rig_from_object the average of its cameras' rig_from_cam cam_from_object.
//   3. Ceres under a robust loss; corners and tips beyond outlier_sigmas x the robust scale of
//      the normalised residuals are left out; a second solve, least squares.
//   4. Covariance of every estimated rig_from_cam from the Jacobian at the optimum: the time
//      steps eliminated (Schur complement of J^T J), inverted, scaled by the a-posteriori
//      variance factor of the noise (options.scale_covariance; chi2 less what the fixed errors
//      below are expected to leave in it, over dof). Then fixed errors propagated to first
//      order and added unscaled, each the same in every frame: the layout's (every marker's
//      pose and post height, with its covariance), each camera's calibration
//      (CameraModel::intrinsics_covariance_factor) and the reference camera's own rig_from_cam
//      covariance (which moves every other camera with it).
// Frames and units (docs/conventions.md): rig_from_cam and rig_from_object map into the rig
// frame, metres and radians; a covariance is 6x6 [rotation, translation], the rotation a small
// angle about the RIG axes: rig_from_cam_true = exp([d_rot]x) R, t + d_trans (the rig file's).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/fusion/object_pose.h"
#include "svms/fusion/rig_pose_estimator.h"
#include "svms/geometry/pose.h"

namespace svms {

struct RigSurveyOptions {
  // The measurement model (pixel sigmas, use_tips) and which fixed errors enter the covariance
  // (use_layout_covariance, use_calibration_covariance); its robust and rejection settings
  // serve step 1 only.
  ObjectPoseOptions measurement;
  // The camera whose rig_from_cam is held fixed (the gauge).
  int reference_camera = 0;
  // Add the reference camera's rig_from_cam covariance, when given, to the others'.
  bool use_reference_covariance = true;
  // Step 2's robust average: a sample is an inlier within these of the medoid.
  double init_inlier_angle_deg = 3;
  double init_inlier_distance = 0.05;  // metres
  // Step 3: Cauchy loss at loss_scale sigmas; rejection at outlier_sigmas x max(1, the robust
  // scale: the median of the normalised residuals' norms / 1.1774, a 2D standard normal's).
  double loss_scale = 3;
  bool reject_outliers = true;
  double outlier_sigmas = 5;
  int max_iterations = 100;
  int num_threads = 1;
  // Step 4: scale the measurement part of the covariance by the noise's variance factor.
  bool scale_covariance = true;
  // The cameras' names for messages, in the rig's order; empty: "camera 0", "camera 1", ...
  std::vector<std::string> camera_names;

  Status Check() const;
};

// The observations of one time stamp: MarkerObservation::camera names the camera of each
// (ObservationsFromDetections on that camera's detections, with `camera` set).
struct RigSurveyFrame {
  double timestamp = 0;
  std::vector<MarkerObservation> observations;
};

struct RigSurveyCamera {
  Pose rig_from_cam;
  // [rotation, translation], rotation about the rig axes. The reference camera's is its input
  // covariance (absent if it had none); absent for every camera if the solve failed.
  std::optional<PoseCovariance> covariance;
  bool reference = false;
  int frames = 0;             // time steps in which it saw a marker used
  int markers = 0;            // marker observations used
  int points = 0;             // corners and tips used
  int points_rejected = 0;    // left out as outliers
  double rms_px = 0;          // RMS pixel residual per coordinate of its points
  double rms_normalised = 0;  // RMS of its residuals / sigma, per coordinate
};

struct RigSurveySummary {
  bool success = false;
  std::string message;         // why not
  int frames_used = 0;         // time steps with a rig_from_object
  int residuals = 0;           // 2 per point
  int parameters = 0;          // 6 per time step used and per estimated camera
  double rms_normalised = 0;   // sqrt(chi2 / residuals)
  double chi2 = 0;             // sum of squared normalised residuals at the optimum
  int dof = 0;                 // residuals - parameters
  double variance_factor = 1;  // chi2 / dof
  // The share of chi2 that the fixed errors (layout, calibration) are expected to leave in the
  // residuals, and the noise's variance factor without it, (chi2 - fixed_chi2) / dof (at least
  // the 1 % quantile of chi2(dof) / dof): what scales the measurement part of the
  // covariance.
  double fixed_chi2 = 0;
  double noise_variance_factor = 1;
  bool covariance_scaled = false;  // the measurement part was multiplied by noise_variance_factor
  bool layout_in_covariance = false;
  bool calibration_in_covariance = false;
  bool reference_in_covariance = false;
  double initial_cost = 0, final_cost = 0;  // Ceres' 0.5 chi2, first and last solve
  int iterations = 0;
  double seconds = 0;
};

struct RigSurveyResult {
  std::vector<RigSurveyCamera> cameras;    // in the rig's order
  std::vector<Pose> initial_rig_from_cam;  // step 2's
  // Per input frame: rig_from_object, absent where no camera gave a start.
  std::vector<std::optional<Pose>> rig_from_object;
  RigSurveySummary summary;
};

// Surveys the rig. `cameras` as SolveRigObjectPose takes them (each camera's model outlives the
// call; rig_from_cam the starting value, of which only the reference's is used;
// rig_from_cam_covariance the reference's input covariance). Errors (one line, also in
// result->summary.message): bad options, an observation naming no camera, a camera that is not
// connected to the reference through time steps seen by both (its extrinsics are not
// determined), a failed solve, a covariance that is not positive definite.
Status SurveyRig(const std::vector<RigCameraView>& cameras,
                 const std::vector<RigSurveyFrame>& frames, const RigSurveyOptions& options,
                 RigSurveyResult* result);

// The observations of one time stamp from the rig's frames: images[c] (empty: no frame from
// camera c) detected and fused by `estimator`'s camera c alone (its PoseEstimator), its markers
// of layout 0 tagged with camera c. `images` holds one entry per camera (checked by the caller).
RigSurveyFrame RigSurveyFrameFromImages(const RigPoseEstimator& estimator,
                                        const std::vector<cv::Mat>& images, double timestamp);
// `estimator`'s cameras as SurveyRig takes them: each one's model (owned by the estimator),
// rig_from_cam and its covariance from the rig file.
std::vector<RigCameraView> RigSurveyViews(const RigPoseEstimator& estimator);

}  // namespace svms
