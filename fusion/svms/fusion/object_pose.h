// One object pose from every visible marker at once.
//
// The unknown is cam_from_object (6 parameters). Every corner and post tip of every detected
// marker of the layout is one observation of a known point of the object: its pixel is
// predicted through the camera's mrcal lens model from the marker's surveyed object_from_marker
// and compared with the detection. Each marker's stripe and decal edges, where its detector
// pose fitted them, join as their quadratic about that pose (use_edges). The fit is one weighted
// least-squares problem over all of them (not an average of per-marker poses), solved by
// Gauss-Newton:
//
//   - Noise model per marker: the corners' and the tip's pixel noise (isotropic, per point)
//     plus the layout's own uncertainty pushed into pixels to first order,
//       R_m = diag(sigma_px^2) + J_layout Sigma_layout J_layout^T,
//     a full (2k x 2k) covariance for the k points of marker m (its points move together when
//     the marker's surveyed pose is off). The fit whitens each marker's residuals with R_m, so
//     the pose covariance (J^T R^-1 J)^-1 includes both the image noise and the layout's.
//     Cross-covariances between markers are not in a layout file and are taken as zero.
//   - The camera calibration's uncertainty, when the camera carries it (camera_covariance.h):
//     the intrinsics' error Sigma_theta = L L^T moves the optimum by d pose = S d theta,
//     S = -(J^T W J)^-1 J^T W d pixel / d theta, and S L L^T S^T is added to the covariance.
//     It is the same error in every frame: a bias along a sequence, not noise.
//   - Robust: a marker whose whitened residual is large is down-weighted (Cauchy on its
//     Mahalanobis norm per coordinate) during the iterations; after convergence, single
//     outlying points (a corner hidden by the post, a glint taken for the tip) are left out,
//     then whole markers whose chi-square exceeds the 99.9 % quantile, one at a time, each
//     followed by a new fit.
//   - Start: each marker's own pose (Detection::cam_from_marker) gives a candidate
//     cam_from_object; the candidate with the least robust cost over all markers is refined.
//
// Frames and units (docs/conventions.md, docs/flight-interface.md): cam_from_object maps object
// points (metres) into the camera frame; the covariance is ordered [rotation, translation], the
// rotation a small angle about the camera axes (radians), the translation of tvec (metres):
// cam_from_object_true = exp([d_rot]) R_est, t_est + d_trans.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "svms/camera/camera.h"
#include "svms/detect/detector.h"
#include "svms/detect/marker_pose.h"
#include "svms/geometry/pose.h"
#include "svms/marker/layout.h"

namespace svms {

struct ObjectPoseOptions {
  // Pixel noise of a refined corner, each axis, for a marker whose square's shortest side is
  // 30 px; it scales as (30 / side)^corner_sigma_exponent (a line fit over more edge pixels is
  // better), never below min_corner_sigma_px. Measured on the simulator's mockup survey
  // images (docs/flight-interface.md).
  double corner_sigma_px = 0.05;
  double corner_sigma_exponent = 0.5;
  // 0.002: on renders with 256 rays on edge pixels the corners of 60 px markers are found to
  // 0.006 px RMS, and their line-fit sigma is honest there.
  double min_corner_sigma_px = 0.002;
  // When the detector measured a corner's sigma from its line fits (Detection::corner_sigma),
  // use corner_fit_scale times that instead of the size model (at least min_corner_sigma_px).
  // 0: the model's own (CornerFitScale), per marker: kCornerCovarianceScale where its corners
  // are taken with their joint covariance, kCornerFitScale where they are taken as independent
  // (marker_pose.h).
  bool corner_sigma_from_fit = true;
  double corner_fit_scale = 0;
  // Added in quadrature to corner_fit_scale x the line-fit sigma: the part of a corner's error
  // that more edge points do not average away. Pixels, each axis. 0: with the edge profile
  // taken along the pixel rows (CornerRefineOptions::edges_along_rows) that part is gone on the
  // simulator, and 0.004 (with a 0.01 px floor) makes large markers' corners conservative
  // (per-axis Z^2 0.37 at 60 px on the compare size sweep).
  double corner_sigma_systematic_px = 0;
  // With corner_sigma_from_fit: the corners of a marker are correlated as the detector's line
  // fits say (Detection::corner_covariance: two corners on one side err in opposite directions
  // across it), scaled by corner_fit_scale^2; each corner's own block keeps the variance
  // above (systematic term and floor included). false: independent corners. Off by default:
  // on the linear approach it brings the mean NEES into its band (5.27 -> 5.92) and the errors
  // down by a fifth, but on the same approach stored as JPEG (sRGB, q85, 0.7 px defocus) it
  // makes the covariance optimistic (NEES 6.87 -> 12.25, 95th percentile 17 -> 33): there the
  // corners' errors are not the independent edge points' the model assumes
  // (docs/flight-interface.md).
  bool corner_covariance_from_fit = false;
  double min_tip_sigma_px = 0.3;  // floor on the detector's own tip sigma
  bool use_tips = true;           // post tips as observations
  // Each marker's stripe and decal edges, where its detector pose fitted them
  // (MarkerObservation::edge_points): their quadratic about the detector's cam_from_marker
  // (edge_information, edge_offset, the same residual as the single-marker fit, EdgeResidual
  // in marker_pose.h) joins the marker's residuals, up to 6 rows whitened by it, with the
  // layout's uncertainty (and in a rig the camera's extrinsics) pushed into them like into
  // the corners. Not for a marker flagged ambiguous (the quadratic holds about its kept planar
  // pose only). Linearised at the detector's pose: the
  // fused pose moves a marker by a fraction of a degree from it, where the edges' normals do
  // not change. The camera calibration's share of the covariance leaves the edges out.
  bool use_edges = true;
  bool use_layout_covariance = true;  // add the layout's uncertainty to the noise model
  // Add the camera calibration's uncertainty to the pose covariance, when the camera carries
  // one (CameraModel::intrinsics_covariance_factor, camera_covariance.h).
  bool use_calibration_covariance = true;
  // In a rig (SolveRigObjectPose): add each camera's rig_from_cam uncertainty, when it has one,
  // the same way (a fixed error per camera, propagated to first order).
  bool use_extrinsics_covariance = true;
  // Robust weight of a marker per iteration: 1 / (1 + (n / robust_k)^2), n its whitened RMS
  // residual per coordinate (Cauchy: a wrong marker's pull fades instead of staying).
  double robust_k = 3;
  double reject_quantile = 0.999;  // a marker is rejected when its chi-square exceeds this quantile
  // A single corner or tip is left out when its residual exceeds this many of its sigmas
  // (pixel noise and layout uncertainty; per axis) and its marker keeps 3 points or more.
  double point_reject_sigma = 5;
  // The covariance is scaled by the frame's variance factor, estimated as
  // (variance_prior_dof + chi2) / (variance_prior_dof + dof): the nominal noise model counts as
  // this many degrees of freedom of evidence, the frame's residuals as theirs. 0: no scaling.
  double variance_prior_dof = 0;
  int max_iterations = 20;
  // Flags (ObjectPose::poorly_conditioned): rotation sigma above this (degrees) or
  // translation sigma above this fraction of the range.
  double max_rotation_sigma_deg = 1.0;
  double max_translation_sigma_fraction = 0.02;
  // Where the fit rests on one marker whose single-marker pose also fitted the stripe's and
  // the decal's outer edges (MarkerObservation::edge_points > 0; detector step 10c), none of
  // whose points was rejected here: the result is that pose and covariance moved to the
  // object (ObjectPoseFromMarker, the layout's covariance added), so that it is never worse
  // than svms detect's own. The refit over the same corners, tip and edges (use_edges) would
  // differ by the tip's floor (min_tip_sigma_px) and the layout's post-height sigma only.
  // In a rig, composed with the camera's rig_from_cam (its covariance added); only where the
  // detector's covariance carries the camera calibration's share exactly when this fit's would.
  // Not for a marker the detector flagged ambiguous (its edges are not in the fit either).
  bool use_marker_pose_with_edges = true;
};

// One marker's observations: which layout entry, the detection's corners and tip.
struct MarkerObservation {
  int id = -1;
  int camera = 0;  // which camera of a rig saw it (SolveRigObjectPose); ignored by SolveObjectPose
  Pose object_from_marker;  // from the layout
  MarkerModel model;        // the detected marker's model (inner model for an inner marker)
  std::optional<PoseCovariance> layout_covariance;  // object axes (layout.h)
  std::optional<double> post_height_sigma;          // metres
  std::array<Eigen::Vector2d, 4> corners;           // pixels, TL, TR, BR, BL
  double side_px = 30;                   // shortest side of the square in the image, pixels
  std::array<double, 4> corner_sigma{};  // from the detector's line fits, px (0: unknown)
  // Their joint covariance from the same fits (Detection::corner_covariance; zero: unknown).
  Eigen::Matrix<double, 8, 8> corner_covariance = Eigen::Matrix<double, 8, 8>::Zero();
  std::optional<TipObservation> tip;
  std::optional<Pose> cam_from_marker;  // the detector's single-marker pose (a start)
  bool pose_ambiguous = false;          // the detector could not tell its two planar poses apart
  // The detector's widening of its single-marker covariance for the other planar solution
  // ([rotation, translation], camera axes, about the marker's origin): added, moved to the
  // object's origin, to the fused covariance when this is the only marker used.
  PoseCovariance ambiguity_covariance = PoseCovariance::Zero();
  // Where the detector flagged the pose ambiguous: its other planar pose, and that pose's share
  // of the likelihood, in (0.01, 0.5] (Detection::alternative_pose, alternative_weight).
  std::optional<Pose> alternative_cam_from_marker;
  double alternative_weight = 0;
  // The detector's covariance of cam_from_marker (Detection::covariance: [rotation,
  // translation], camera axes, about the marker's origin; its widening for the other planar
  // solution included, and the calibration's where calibration_in_marker_covariance), and how
  // many stripe and decal edge points its fit used (Detection::edge_points).
  PoseCovariance marker_covariance = PoseCovariance::Zero();
  bool calibration_in_marker_covariance = false;
  int edge_points = 0;
  // Those edge points' own quadratic about cam_from_marker (Detection::edge_information,
  // edge_offset: [rotation, translation], camera axes; MarkerPose).
  Eigen::Matrix<double, 6, 6> edge_information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> edge_offset = Eigen::Matrix<double, 6, 1>::Zero();
};

struct ObjectPose {
  bool valid = false;
  Pose cam_from_object;
  PoseCovariance covariance = PoseCovariance::Zero();  // [rotation, translation], camera axes
  int markers_seen = 0;     // observations given (markers of the layout detected)
  int markers_used = 0;     // after rejection
  int points_used = 0;      // corners and tips of the markers used
  int points_rejected = 0;  // single corners or tips left out as outliers
  std::vector<int> ids_used, ids_rejected;
  // The camera of each entry of ids_used and ids_rejected (always 0 for one camera): in a rig,
  // one marker seen by two cameras is two observations.
  std::vector<int> cameras_used, cameras_rejected;
  double rms_px = 0;           // RMS pixel residual (per coordinate) of the points used
  double chi2 = 0;             // whitened residual sum of squares of the points used
  int dof = 0;                 // 2 * points_used + edge_rows - 6
  int edge_rows = 0;           // rows of the markers' edge quadratics in the fit (use_edges)
  double variance_factor = 1;  // the scale applied to the fit's covariance (variance_prior_dof)
  bool ambiguous = false;      // one marker, and its planar pose could not be told apart
  // With `ambiguous`, where the detector gave the marker's other planar pose: the object's pose
  // under it, and its share of the likelihood, in (0.01, 0.5]. The one marker's alternative
  // moved to the object by the same marker_from_object.
  std::optional<Pose> alternative_cam_from_object;
  double alternative_weight = 0;
  // The covariance includes the camera calibration's uncertainty (the camera carried one).
  bool calibration_in_covariance = false;
  // A rig's: the covariance includes the cameras' rig_from_cam uncertainty (some had one).
  bool extrinsics_in_covariance = false;
  bool poorly_conditioned = false;  // sigmas above ObjectPoseOptions' limits
  // The pose and covariance are the one marker's own, with its stripe and decal edges
  // (ObjectPoseOptions::use_marker_pose_with_edges); rms_px, chi2, dof and variance_factor
  // still describe the refit over its corners, tip and edges.
  bool from_marker_pose = false;
  std::string message;  // why not valid

  // The share of `covariance` that is one error common to every frame of a sequence, not
  // noise: the camera calibration's (calibration_in_covariance) and the rig extrinsics'
  // (extrinsics_in_covariance), as B B^T with B = bias_factor() (6 x bias_columns()). The
  // columns keep their meaning from frame to frame of one estimator: first each camera's
  // calibration, the columns of its CameraModel::intrinsics_covariance_factor L (camera order),
  // then each camera's rig_from_cam, 6 columns of the symmetric square root of its covariance
  // Sigma^(1/2) (camera order); a camera that sees no marker in a frame keeps its columns, as
  // zeros. If each model's intrinsics are the true ones plus L z_c and each camera truly sits
  // at exp([e_rot]) R, t + e_trans with e = Sigma^(1/2) z_e, the pose's error PoseError(truth,
  // estimate) is B z plus the frame's noise, to first order, z the z_c and z_e stacked in the
  // columns' order. So the errors of a sequence are e_f = B_f z + n_f with one draw z ~ N(0, I)
  // for all its frames: a filter must not average that part away, and a test of a sequence's
  // mean NEES must allow for the one draw (sequence_nees.h). Where the pose is the one marker's own
  // (from_marker_pose), the calibration columns are this fit's sensitivity over the marker's
  // corners and tip, which the detector's own share in `covariance` is computed from by the same
  // rule, with the detector's point sigmas where they differ from this fit's. No columns when
  // neither error is in the covariance. The surveyed layout's error is the same in every frame
  // too, but it is not here: it enters each marker's whitening (R_m above), and its columns
  // would need each marker's place in the whole layout and the survey's covariance between
  // markers, which a layout file does not keep (on the approach's frames the surveyed layout's
  // covariance moves the mean NEES 3.89 -> 3.92 against the true layout's).
  // Stored column-major in bias_factor_values, whose capacity a reused ObjectPose keeps (no
  // allocation once warmed up).
  std::vector<double> bias_factor_values;
  int bias_columns() const { return static_cast<int>(bias_factor_values.size() / 6); }
  Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> bias_factor() const {
    return {bias_factor_values.data(), 6, bias_columns()};
  }
};

// Observations from detections: every detection whose ID is in the layout (as a marker, or
// as the inner marker of a dual entry). A post seen by both markers of a dual gives one tip.
std::vector<MarkerObservation> ObservationsFromDetections(const std::vector<Detection>& detections,
                                                          const Layout& layout);
// The same into *observations (replaced; its capacity is reused, no allocation once grown).
void ObservationsFromDetections(const std::vector<Detection>& detections, const Layout& layout,
                                std::vector<MarkerObservation>* observations);

// The scale of the line-fit sigmas (ObjectPoseOptions::corner_fit_scale) for a marker whose
// corners are taken with their joint covariance (`correlated`) or as independent.
double CornerFitScale(const ObjectPoseOptions& options, bool correlated);

// The corner sigma the size model gives a marker of `side_px` pixels.
double CornerSigma(const ObjectPoseOptions& options, double side_px);

// The measurement model's pixel noise, each axis, that every fit of these observations uses
// (SolveObjectPose, SolveRigObjectPose, the rig survey): corner k (0-3) of `m` gets
// corner_fit_scale x its line-fit sigma (with the systematic term, at least
// min_corner_sigma_px) when corner_sigma_from_fit and the detector gave one, else the size
// model's CornerSigma; the post tip its detector's sigma, at least min_tip_sigma_px.
double CornerPixelSigma(const ObjectPoseOptions& options, const MarkerObservation& m, int k);
double TipPixelSigma(const ObjectPoseOptions& options, const MarkerObservation& m);

// The object pose one marker's single-marker pose gives: cam_from_object = cam_from_marker
// object_from_marker^-1, with m.marker_covariance moved from the marker's origin to the
// object's ([rotation, translation], camera axes) and, with `with_layout` and where the layout
// gives one, the layout's covariance of object_from_marker (object axes) added to first order:
// an error (e_rot, e_trans) of it moves the object by d_rot = -R e_rot, d_trans = -R e_trans -
// [R t_om]x R e_rot (R the cam_from_object rotation, t_om the marker's place in the object).
// False when m has no cam_from_marker.
bool ObjectPoseFromMarker(const MarkerObservation& m, bool with_layout, Pose* cam_from_object,
                          PoseCovariance* covariance);

// Makes *pose a fresh ObjectPose{} while its vectors and message keep their capacity: a result
// reused frame after frame allocates nothing once grown, even across frames with no pose.
void ResetObjectPose(ObjectPose* pose);

// Solves cam_from_object. Returns an invalid pose with a message when there is nothing to fit
// (no observation, the camera cannot project, a singular problem).
ObjectPose SolveObjectPose(const CameraModel& camera, const std::vector<MarkerObservation>& obs,
                           const ObjectPoseOptions& options);
// The same into *pose (replaced). The capacity of its vectors and message is reused, and the
// solver's own buffers are kept per thread, so that a warmed-up call on a valid frame makes no
// heap allocation.
void SolveObjectPose(const CameraModel& camera, const std::vector<MarkerObservation>& obs,
                     const ObjectPoseOptions& options, ObjectPose* pose);

// One camera of a rig, as SolveRigObjectPose sees it: its lens model (not owned, outlives the
// call), where it sits on the rig, and optionally that pose's uncertainty, 6x6 [rotation,
// translation], rotation a small angle about the RIG axes (radians), translation in metres:
// rig_from_cam_true = exp([d_rot]) R, t + d_trans.
struct RigCameraView {
  const CameraModel* camera = nullptr;
  Pose rig_from_cam;
  std::optional<PoseCovariance> rig_from_cam_covariance;
};

// The same solve over the markers seen by several cameras at one time stamp, rigidly mounted on
// a rig: observation i is seen by cameras[obs[i].camera]. The unknown is rig_from_object, and
// the result's `cam_from_object` holds it (the rig frame takes the camera's place: its
// covariance is [rotation, translation], rotation about the RIG axes). Every marker's block,
// whitening, robust weight and rejection are those of SolveObjectPose; each camera's
// calibration covariance enters as its own independent error, and so does each camera's
// rig_from_cam covariance (options.use_extrinsics_covariance): d pose / d rig_from_cam to
// first order, S Sigma_c S^T added after the variance factor. The robust weight and the
// rejection tests of such a camera's markers count that error's pixel spread too. A marker seen by
// two cameras is two observations (its pixel noise in the two images is independent; the layout's
// error the two share is then counted twice as independent, slightly optimistic for that marker).
// An observation naming no camera of the rig gives an invalid pose with a message.
ObjectPose SolveRigObjectPose(const std::vector<RigCameraView>& cameras,
                              const std::vector<MarkerObservation>& obs,
                              const ObjectPoseOptions& options);
void SolveRigObjectPose(const std::vector<RigCameraView>& cameras,
                        const std::vector<MarkerObservation>& obs, const ObjectPoseOptions& options,
                        ObjectPose* pose);

// The error of `estimate` against `truth` in the covariance's coordinates:
// [log(R_truth R_est^T), t_truth - t_est] (radians about camera axes, metres).
Eigen::Matrix<double, 6, 1> PoseError(const Pose& truth, const Pose& estimate);
// Normalised estimation error squared: e^T covariance^-1 e (chi-square with 6 dof when the
// covariance is right). NaN if the covariance is singular.
double Nees(const Pose& truth, const Pose& estimate, const PoseCovariance& covariance);

}  // namespace svms
