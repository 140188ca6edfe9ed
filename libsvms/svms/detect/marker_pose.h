// Detector steps 9-10: the post tip and the pose of one marker.
//
// The four corners of a planar square leave a two-fold ambiguity at small sizes and oblique
// views (IPPE gives both solutions). The post tip, off the plane, settles it: each solution
// predicts where the tip should be and the white tip (or the well's white bottom) is searched
// there. Each solution is then refined by Gauss-Newton over the corners and the tip together,
// through the camera's mrcal lens model, each point weighted by its own uncertainty, and the
// one with the least weighted squared residuals is kept; its 6x6 covariance is (J^T W J)^-1,
// widened to cover the other solution as far as the data leave it likely.
//
// Why not Ceres here: six parameters and at most five points per marker, solved for every
// marker in every frame; a dense Gauss-Newton on Eigen costs microseconds and allocates
// nothing, while Ceres' problem setup alone costs more than the whole solve.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "svms/camera/camera.h"
#include "svms/detect/corner_refine.h"
#include "svms/geometry/pose.h"
#include "svms/marker/marker_model.h"

namespace svms {

struct TipObservation {
  Eigen::Vector2d pixel;
  double sigma_px = 0.5;  // standard deviation of the centroid, each axis
};

// The factor between a refined corner's error and the sigma its side fits give
// (RefinedCorners::corner_sigma), shared by single-marker pose, fusion and the survey: 1, the
// line fits' sigma as they give it, fitted to no render. Each corner's sigma carries its own
// degrees of freedom (CornerRefineOptions::small_sample_variance); against it the corners'
// per-axis Z^2 on the linear sensor profile has means of 0.94-1.14 by size from 8 to 60+ px
// (`svms bench profiles`, `scripts/profiles_by_size`; docs/flight-interface.md says what the
// pose's NEES does with it).
inline constexpr double kCornerFitScale = 1.0;
// The same factor where a marker's corners are taken with their joint covariance from the line
// fits (RefinedCorners::corner_covariance; the fused pose, object_pose.h). Not fitted to a pose
// test: the square root of the corners' per-axis Z^2 against corner_sigma over 150 synthetic
// 36 px squares with white noise (exact area-sampled edges, no renderer;
// corner_refine_test.cc, TheCornersJointCovarianceCarriesTheSidesSlopes checks it within 0.04):
// 1.133 with that test's seed, so 1.06. Used by MarkerPoseOptions::corner_covariance_from_fit
// too.
inline constexpr double kCornerCovarianceScale = 1.06;

struct MarkerPoseOptions {
  // Standard deviation of a refined corner, each axis, pixels: corner_fit_scale x the sigma
  // its side fits give (RefinedCorners::corner_sigma), at least min_corner_sigma_px; where
  // that is not known (0), corner_sigma_px (kCornerFitScale: see above).
  double corner_sigma_px = 0.1;
  double corner_fit_scale = kCornerFitScale;
  double min_corner_sigma_px = 0.002;
  // Where the detector gave the corners' joint covariance from its line fits
  // (RefinedCorners::corner_covariance: two corners on one side err in opposite directions
  // across it), whiten the four corners' residuals with corner_covariance_scale^2 times it
  // instead of taking them as independent (corner_fit_scale); the tip and the edges as before.
  // The fused pose's ObjectPoseOptions::corner_covariance_from_fit, for one marker. Off by
  // default: it makes the NEES on linear frames and the orientation's more honest, but on the
  // blurred sensor profiles, whose small markers' corners are still overconfident, it lowers
  // the share of NEES below 12.59 (`svms bench profiles --correlated-corners`, figures in
  // docs/benchmarks.md).
  bool corner_covariance_from_fit = false;
  double corner_covariance_scale = kCornerCovarianceScale;
  double tip_search_fraction = 0.25;  // search radius, as a fraction of the square's side
  double tip_min_contrast = 0.35;     // tip brighter than black by this fraction of white - black
  // The image's noise at the square's black (standard deviation, image units), where the caller
  // knows it; 0 if not known. A top below a pixel that stands out by its light alone is held
  // to the larger of this and what the pixels about it show (FindTip). The detector sets it
  // from its frame's noise model where it has one (16-bit and linearised frames; 0 where the
  // codes hide the noise, as in a JPEG), over the value given here.
  double black_noise_sigma = 0;
  // A white top smaller than this in the image (radius, pixels) is not looked for. Down to a
  // third of a pixel the top still shows in the square's black (on a 10 px marker at 8-bit:
  // two pixels 35 and 42 levels above black, with white 143 above) and tells the two planar
  // solutions apart; FindTip reads it as a sub-pixel blob (its tip_radius_px).
  double tip_min_radius_px = 0.35;
  // The white stripe's outer edge, where a black bit cell borders it (the decoded ID says
  // which), is a square 5/3 the size of the black one: its edge points are added to the pose
  // fit (point-to-line), which nearly triples the perspective leverage on the orientation.
  // Only where the cells are at least stripe_edge_min_cell_px wide in the image.
  bool use_stripe_edge = true;
  double stripe_edge_min_cell_px = 3;
  // Likewise the decal's outer edge (6 cells from the centre, twice the black square's half
  // side) where a white bit cell meets a darker skin; with use_stripe_edge only.
  bool use_decal_edge = true;
  // Add the camera calibration's uncertainty to the covariance when the camera carries one
  // (CameraModel::intrinsics_covariance_factor): S L L^T S^T, S = d pose / d intrinsics of the
  // fit over the corners and tip.
  bool use_calibration_covariance = true;
};

// A point on a straight edge of the marker: `point` on the edge and `direction` along it
// (marker frame, metres), the edge point found in the image (pixels) and its sigma across the
// edge (pixels). The residual is the pixel distance across the edge's image.
struct EdgeObservation {
  Eigen::Vector3d point, direction;
  Eigen::Vector2d pixel;
  double sigma_px = 0.1;
};

struct MarkerPose {
  Pose cam_from_marker;
  PoseCovariance covariance = PoseCovariance::Zero();  // [rotation, translation], camera axes
  std::optional<TipObservation> tip;
  // Two planar solutions that the corners and tip do not tell apart: the other one has more
  // than 1 % of the likelihood (its weighted squared residuals exceed the kept one's by less
  // than 9.2) and is more than 2 degrees away (a marker seen within a degree of head-on is not
  // flagged). The covariance spans both (a mixture about the kept pose) either way. Where both
  // refined to one pose, the kept pose's planar twin (PlanarTwin, ippe.h) stands for the other,
  // with the weight Phi(-sqrt(D) / 2): how often noise swaps two poses that put the corners and
  // tip D (squared sigmas, summed) apart.
  bool ambiguous = false;
  // What the other planar solution adds to `covariance` (same axes): w (C' - C + d d^T), zero
  // when it is the same pose or negligible. A fit over other points (fusion) adds it likewise.
  PoseCovariance ambiguity_covariance = PoseCovariance::Zero();
  // Where `ambiguous`: the other planar solution (the other candidate as refined, or the kept
  // pose's planar twin) and its share of the likelihood, in (0.01, 0.5]: what a consumer that
  // can check against other data (another marker, the previous frame) may take instead.
  std::optional<Pose> alternative;
  double alternative_weight = 0;
  double rms_px = 0;  // RMS of the corner (and tip) residuals after the fit
  // Stripe and decal edge points in the kept fit (MarkerPoseOptions::use_stripe_edge); 0: the
  // pose rests on the corners and tip alone.
  int edge_points = 0;
  // What those edge points alone say about cam_from_marker, linearised at it (EdgeQuadratic):
  // their weighted squared residuals are (d - edge_offset)^T edge_information (d -
  // edge_offset) + const for a small change d = [rotation, translation] of cam_from_marker
  // (left perturbation, camera axes: radians, metres). Zero without edge points. A fit over
  // other points too (the fused pose) adds the edges through it.
  Eigen::Matrix<double, 6, 6> edge_information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> edge_offset = Eigen::Matrix<double, 6, 1>::Zero();
  int solutions = 0;                       // planar solutions considered
  bool calibration_in_covariance = false;  // the camera calibration's uncertainty is included
  // The corners were fitted with their joint covariance (corner_covariance_from_fit and the
  // detector gave one), not as independent points.
  bool joint_corners = false;
  std::string failure;  // when EstimateMarkerPose returns false: why (one phrase)
};

// The white blob nearest `predicted` within `radius` pixels: the connected pixels brighter
// than the midpoint of `black` and `white`. nullopt if none is clearly there. `tip_radius_px`
// is the white top's expected radius in the image. Up to 5 px the top's place is fitted to
// the pixels around it as a disc of that radius (FitDisc, disc_fit.h: a centroid would lock
// to the pixel centres), with the fit's own sigma; below a pixel its light is spread over two
// to four pixels and no pixel reaches the midpoint, so the brightest must stand out by
// min_contrast x min(1, pi r^2 / 2) only, or (behind a lens's blur, which lowers the peak) the
// 3 x 3 about it hold min_contrast x pi r^2 x (white - black) of light, 5 sigmas of its noise
// clear, and be ringed by dark pixels (nothing else bright within 2 px). Larger tops, and a top
// with something else bright next to it or too near the image's border for the fit's window, give
// the blob's centroid weighted by brightness (with a sigma that counts its pixel locking, for a top
// of at most 5 px).
std::optional<TipObservation> FindTip(const cv::Mat& image, const Eigen::Vector2d& predicted,
                                      double radius, double black, double white,
                                      double min_contrast, double tip_radius_px = 1e9);

// What one FindTip call found, for a later call on the same image with the same radius, black,
// white, min_contrast, tip_radius_px, square and noise_sigma but another `predicted`: when that
// search starts in the same top (from the same pixel, for a top below a pixel; else from a pixel of
// the same blob, at the same threshold) and its window holds that whole blob, the answer is the
// same, and it is returned without flooding and fitting again (EstimateMarkerPose's two planar
// candidates usually predict the tip within a pixel or two of each other). Any other call
// searches afresh and keeps its own answer. The memo holds no pixel values: it must not
// outlive the image's contents.
struct TipSearchMemo {
  int reused = 0;  // calls answered from the memo (for tests)
  // Internal: the arguments, seed, threshold and blob of the kept answer.
  bool valid = false;
  const void* data = nullptr;
  int rows = 0, cols = 0, type = 0;
  double radius = 0, black = 0, white = 0, min_contrast = 0, tip_radius_px = 0;
  int seed_x = -1, seed_y = -1;
  double local_thr = 0;
  double noise_sigma = 0;
  bool has_square = false;  // FindTip's `square`, and its corners
  std::array<Eigen::Vector2d, 4> square;
  std::vector<std::pair<int, int>> blob;                     // pixels (x, y)
  int blob_x0 = 0, blob_x1 = -1, blob_y0 = 0, blob_y1 = -1;  // bounding box, inclusive
  std::optional<TipObservation> tip;
};
// `square` (may be null): the black square's corners in the image (pixels). A top below a
// pixel must be ringed by dark pixels except, there, where the ring lies outside the square or
// within kTipRingEdgeMarginPx of its sides: behind a lens's blur the stripe's light reaches
// them when the top stands near a side (an oblique view of a small marker), and the top is
// then fitted from the 3 x 3 about it; not where the seed lies within kTipCornerReachPx of two
// sides (by a corner, where the stripe's blurred light is all around). `noise_sigma`: the
// image's noise at `black` (standard deviation, image units) where the caller knows it, else
// 0; the noise of the light test above is the larger of it and what the 16 pixels 2 px about
// the top show. The memo answers only a call with the same `square` and `noise_sigma`.
std::optional<TipObservation> FindTip(const cv::Mat& image, const Eigen::Vector2d& predicted,
                                      double radius, double black, double white,
                                      double min_contrast, double tip_radius_px,
                                      TipSearchMemo* memo,
                                      const std::array<Eigen::Vector2d, 4>* square = nullptr,
                                      double noise_sigma = 0);

// Pose of a marker from its corners (marker order: TL, TR, BR, BL as printed, pixels), each
// with its sigma from the side fits (pixels; 0: not known, see MarkerPoseOptions), and their
// joint covariance from the same fits (RefinedCorners::corner_covariance; nullptr or zero: not
// known), used with MarkerPoseOptions::corner_covariance_from_fit.
// False if the camera cannot unproject the corners or no solution is valid; out->failure says
// which.
bool EstimateMarkerPose(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& corners,
                        const MarkerModel& model, const CameraModel& camera, double black,
                        double white, const MarkerPoseOptions& options, MarkerPose* out,
                        const std::array<double, 4>& corner_sigma = {},
                        const Eigen::Matrix<double, 8, 8>* corner_covariance = nullptr);

// The marker-frame point whose image is the centroid of what the camera at `cam_in_marker`
// sees of the white tip. For a post, the centre of its top. For a concave well, the part of
// the white bottom visible through the opening, which slides off-centre as the view tilts;
// `visible_fraction` says how much of the bottom is seen (0 when none).
Eigen::Vector3d VisibleTipPoint(const MarkerModel& model, const Eigen::Vector3d& cam_in_marker,
                                double* visible_fraction);

// The image of a protruding post at `cam_from_marker`: its axis from the marker's centre to
// the top, widened by the larger of its radius and its top's, plus `margin_px`. nullopt
// without a post, for a concave well (it never crosses a side) or if a point does not project.
std::optional<ExcludedRegion> PostSilhouette(const MarkerModel& model, const CameraModel& camera,
                                             const Pose& cam_from_marker, double margin_px);

// Whether `region` reaches any side of the quad `corners` (pixels).
bool RegionTouchesSides(const ExcludedRegion& region,
                        const std::array<Eigen::Vector2d, 4>& corners);

// The camera calibration's share of a pose fit's covariance, added by EstimateMarkerPose:
// S L L^T S^T with S = -(J^T W J)^-1 J^T W d pixel / d intrinsics over the points X (marker
// frame, metres; sigma their pixel sigmas) at cam_from_marker, L the camera's
// intrinsics_covariance_factor ([rotation, translation], camera axes); W whitens the first
// four points together where `corner_whitener` is given (as in RefinePose). False when the
// camera has no factor or a point does not project. Exposed for tests.
bool CalibrationCovariance(const CameraModel& camera, const Pose& cam_from_marker,
                           const std::vector<Eigen::Vector3d>& X, const std::vector<double>& sigma,
                           PoseCovariance* out,
                           const Eigen::Matrix<double, 8, 8>* corner_whitener = nullptr);

// The residual of one edge point at cam_from_marker (R, t): the signed pixel distance from
// e.pixel to the image of the edge's line, across it (along the normal of the projected edge
// direction at the projected e.point), and its row d residual / d [rotation, translation]
// (left perturbation, camera axes). The normal's own change with the pose is left out (it
// multiplies the offset along the edge between the model point's image and the edge point,
// which is tiny). False when the point does not project or the edge's image degenerates.
// The one residual of the stripe and decal edges for every fit that uses them.
bool EdgeResidual(const CameraModel& camera, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const EdgeObservation& e, double* residual, Eigen::Matrix<double, 1, 6>* row);

// The edge points' own quadratic at cam_from_marker: *information = sum of row^T row /
// sigma^2 and *offset = -information^+ sum of row^T r / sigma^2 (EdgeResidual; the
// pseudo-inverse over eigenvalues above 1e-12 of the largest), so that their weighted squared
// residuals at a small change d of the pose are (d - offset)^T information (d - offset) plus a
// constant, to first order. False when a point does not project.
bool EdgeQuadratic(const CameraModel& camera, const Pose& cam_from_marker,
                   const std::vector<EdgeObservation>& edges,
                   Eigen::Matrix<double, 6, 6>* information, Eigen::Matrix<double, 6, 1>* offset);

// Gauss-Newton refinement of cam_from_marker over `points_in_marker` observed at `pixels`
// with per-point sigmas (and `edges`, point-to-line), at most `max_iterations` steps; fills
// the covariance, (J^T W J)^-1 in [rotation, translation], camera axes. With
// `corner_whitener` W (8 x 8, W C W^T = I for the corners' joint covariance C), the first four
// points are the corners and their 8 residuals are whitened by W together (their sigmas are
// not used). Exposed for tests.
bool RefinePose(const CameraModel& camera, const std::vector<Eigen::Vector3d>& points_in_marker,
                const std::vector<Eigen::Vector2d>& pixels, const std::vector<double>& sigmas,
                Pose* cam_from_marker, PoseCovariance* covariance, double* rms_px,
                const std::vector<EdgeObservation>* edges = nullptr, int max_iterations = 10,
                const Eigen::Matrix<double, 8, 8>* corner_whitener = nullptr);

}  // namespace svms
