// The survey's plain structs, free of Ceres: what the user asks for (SurveyOptions: tuning
// knobs with Check()), what the problem is tied to (SurveyConfig: the gauge, the scale bars,
// what is fixed or refined), and what happened (SurveySummary). The solver itself is in
// survey.h; the Ceres cost functions in cost_functions.h.
//
// A survey estimates, from many images of one object carrying several markers:
//   - object_from_marker for every marker (6 DOF each; a dual marker's inner marker is a
//     marker of its own, so their relative pose is surveyed too),
//   - the height of every post (as built is not as drawn: the drawing's height is a prior),
//   - cam_from_object for every image, and optionally the camera's intrinsics.
// Frames and units as in docs/conventions.md: metres, radians, pixels.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/detect/marker_pose.h"

namespace svms {

// Tuning knobs. Defaults suit the SVMS detector's corners (0.1 px) and tips.
struct SurveyOptions {
  // Standard deviation of a detected corner, each axis (pixels): corner_fit_scale x the sigma
  // the detector's side fits give (Detection::corner_sigma), at least min_corner_sigma_px,
  // when corner_sigma_from_fit and the detection has one; corner_sigma_px otherwise. Each
  // corner is then weighted by its own noise (a side at a grazing angle, a small marker, a
  // corner by a shadow's edge) instead of all alike. The scale: kCornerFitScale (marker_pose.h).
  double corner_sigma_px = 0.1;
  bool corner_sigma_from_fit = true;
  double corner_fit_scale = kCornerFitScale;
  // 0.002, as in the fusion (ObjectPoseOptions): on renders with 256 rays on edge pixels large
  // markers' line-fit sigmas are honest below 0.01 px.
  double min_corner_sigma_px = 0.002;
  // Floor on a post tip's standard deviation (pixels); the detector's TipObservation::sigma_px
  // is used when larger.
  double min_tip_sigma_px = 0.3;
  // Standard deviation of the drawing's post height as a prior on the built one (metres).
  double post_height_prior_sigma = 0.002;

  // Robust loss of the first solve, on residuals in units of their sigma:
  // "cauchy", "huber" or "trivial"; `loss_scale` is where it starts to bite (sigmas).
  std::string loss = "cauchy";
  double loss_scale = 3;
  // After the first solve, a corner or tip whose residual exceeds `outlier_sigmas` times the
  // robust scale of all residuals (1.4826 MAD of the normalised residuals) is rejected, and a
  // detection with `outlier_points_per_detection` or more rejected points is dropped whole
  // (a wrong ID or a flipped corner order). The second solve is least squares (no loss), so
  // that its covariance is the textbook one.
  bool reject_outliers = true;
  double outlier_sigmas = 5;
  int outlier_points_per_detection = 2;

  // Initialisation: relative poses of two markers seen in the same image are averaged
  // robustly; a sample further than these from the medoid is left out of the mean.
  double init_inlier_angle_deg = 3;
  double init_inlier_distance = 0.05;  // metres

  int max_iterations = 100;
  double function_tolerance = 1e-12;
  double gradient_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
  int num_threads = 1;

  bool compute_covariance = true;
  // How the covariance is computed (the same numbers either way, to rounding):
  //  kSchurComplement: the Gauss-Newton matrix J^T J with the camera poses eliminated (the
  //    reduced system the rank check builds anyway: markers, posts, intrinsics), inverted. Its
  //    inverse is exactly the marker/post/intrinsics block of the full inverse, and its size
  //    does not grow with the number of images (2000 images x 40 markers: about 300 x 300).
  //  kSparseQr: ceres::Covariance with SPARSE_QR (SuiteSparseQR) on the whole Jacobian.
  //  kDenseSvd: ceres::Covariance with DENSE_SVD: cubic in all parameters, cameras included;
  //    for small problems and checks only.
  enum class CovarianceAlgorithm { kSchurComplement, kSparseQr, kDenseSvd };
  CovarianceAlgorithm covariance_algorithm = CovarianceAlgorithm::kSchurComplement;
  // Scale covariances by the a-posteriori variance factor 2 cost / (m - n) (noise not known
  // a priori). false: covariances assume the sigmas above are right.
  bool scale_covariance = true;
  // When the camera carries its calibration's uncertainty (CameraModel::
  // intrinsics_covariance_factor, e.g. from svms calibrate's sidecar) and the intrinsics are
  // not refined: add what that uncertainty does to every marker pose and post height,
  // S L L^T S^T with S = d layout / d intrinsics at the optimum (camera poses eliminated), to
  // their covariances, unscaled (it is not this survey's noise).
  bool use_calibration_covariance = true;
  // A corner error that repeats in every view of a marker, which no number of views averages
  // away: where a marker's contrast is a few grey levels (in shadow) and the noise is too small
  // to dither the image's integer steps, the edge locator's error is set by the grey levels
  // rather than by the view. Modelled as one outward shift per marker, of unit variance and
  // common to all its views, that moves each corner of a detection by corner_repeat_px_grey /
  // contrast pixels, contrast = that detection's Detection::white - black in the image's own
  // grey levels (a 16-bit image's steps are 256 times finer, and so is the term). Its effect on
  // the layout, S S^T with S = d layout / d shifts (camera poses eliminated), is added to the
  // covariances, unscaled, as the calibration's is. 0: left out; detections without grey
  // levels (white <= black) add nothing. The value is fitted: on the seed-1 rendered mockup
  // (256 rays on edge pixels) the corners of markers in shadow (about 7 grey levels) come out
  // 0.023 px inward on average (markers 12-18; the lit one 0.009 px outward), and
  // 0.023 x 7 = 0.16 (docs/benchmarks.md, survey).
  // Not modelled: that the shifts of different markers share a sign (all seven shadowed
  // markers there came out inward).
  double corner_repeat_px_grey = 0.16;

  // Progress of the solver on stderr.
  bool verbose = false;

  // Ok, or one line naming the bad field and what was expected.
  Status Check() const;
};

// A point on the object named by the marker it is on: "ID" (the centre of the black square),
// "ID.tl", "ID.tr", "ID.br", "ID.bl" (its corners as printed) or "ID.tip" (its post tip).
struct NamedPoint {
  std::string name;
  int marker_id = -1;
  enum class Kind { kCentre, kCorner, kTip } kind = Kind::kCentre;
  int corner = 0;  // for kCorner: 0 TL, 1 TR, 2 BR, 3 BL
};
// Parses "12", "12.tl", "12.tip", ...; the error names `name` and the expected forms.
Status ParseNamedPoint(const std::string& name, NamedPoint* out);

// A measured distance between two named points (a scale bar), metres.
struct ScaleBar {
  NamedPoint a, b;
  double distance = 0;
  double sigma = 1e-4;
};

// A named point whose coordinates in the object frame are known (control point), metres.
struct ControlPoint {
  NamedPoint point;
  Eigen::Vector3d point_in_object = Eigen::Vector3d::Zero();
  double sigma = 1e-4;
};

// What the problem is tied to.
struct SurveyConfig {
  // The gauge (the object frame):
  //  kReferenceMarker: the frame of `reference_id` (its pose is held at the identity);
  //  kControlPoints: three or more non-collinear control points, weighted by their sigmas
  //  (no marker held); the covariances then include the control points' uncertainty.
  enum class Gauge { kReferenceMarker, kControlPoints };
  Gauge gauge = Gauge::kReferenceMarker;
  int reference_id = -1;
  std::vector<ControlPoint> control_points;
  // Scale comes from the marker sizes; scale bars add measured distances.
  std::vector<ScaleBar> scale_bars;

  bool refine_intrinsics = false;
  bool estimate_post_heights = true;  // false: posts held at their drawn height
  // Markers whose pose is held at its initial value (besides the reference), e.g. from a
  // previous survey. Rarely needed.
  std::vector<int> fixed_markers;
  // A disconnected view graph is an error unless this is set; then only the component that
  // holds the reference is surveyed and the others are listed as left out.
  bool drop_disconnected = false;

  // Ok, or one line naming the bad field.
  Status Check() const;
};

// Residual statistics of one image or one marker after the final solve.
struct ResidualStats {
  std::string name;  // image name, or "marker ID"
  int points = 0;    // corners and tips used
  int outliers = 0;  // rejected after the first solve
  double rms_px = 0;
  double max_px = 0;
};

struct RejectedPoint {
  std::string image;
  int marker_id = -1;
  std::string point;  // "tl", "tr", "br", "bl" or "tip"
  double residual_px = 0;
};

// What the survey did.
struct SurveySummary {
  bool success = false;
  std::string message;  // the failure, one line; empty on success

  int images_total = 0, images_used = 0;
  int detections_used = 0;
  int markers_surveyed = 0;
  // Markers left out, each with the reason ("seen in 1 image", "not in the reference's
  // component", "no model").
  std::vector<std::pair<int, std::string>> left_out;
  // The view graph's connected components (marker IDs), largest first.
  std::vector<std::vector<int>> components;

  int residuals = 0, parameters = 0;  // m and n of the final solve
  double initial_cost = 0, first_cost = 0, final_cost = 0;
  int iterations_first = 0, iterations_second = 0;
  double rms_px = 0;           // over all corners and tips of the final solve
  double variance_factor = 1;  // 2 cost / (m - n) of the final solve
  bool covariance_ok = false;
  bool covariance_scaled = false;
  bool calibration_in_covariance = false;    // the camera calibration's uncertainty was added
  bool corner_repeat_in_covariance = false;  // corner_repeat_px_grey's term was added
  // The intrinsics were refined (SurveyConfig::refine_intrinsics): the layout belongs to the
  // refined camera (SurveyResult::camera), not to the input one. refined_camera names the file
  // it was written to, for the report and the layout's name (set by the caller; "" = not
  // written).
  bool intrinsics_refined = false;
  std::string refined_camera;

  std::vector<ResidualStats> per_image, per_marker;
  std::vector<RejectedPoint> rejected;

  double seconds_init = 0, seconds_first = 0, seconds_second = 0, seconds_covariance = 0;
  std::string ceres_report_first, ceres_report_second;  // Ceres' BriefReport()

  std::string BriefReport() const;  // a few lines for a terminal
  // The surveyed layout's name (Layout::name): how many images, and what its covariances hold.
  std::string LayoutName() const;
};

}  // namespace svms
