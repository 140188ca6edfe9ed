// The uncertainty of a calibrated camera's intrinsics, kept in a JSON sidecar next to its mrcal
// .cameramodel: CAMERA.cameramodel -> CAMERA.cameramodel.covariance.json. `svms calibrate`
// writes both; PoseEstimator::CreateFromFiles (svms pose, svms bench pose, the C API) reads the
// sidecar when it is there, so that the pose covariance includes the calibration's error.
//
// Why a sidecar: mrcal 2.2 keeps a model's uncertainty as its whole optimisation problem
// ('optimization_inputs'), which only its Python tools can write and evaluate; a field of our
// own inside the .cameramodel would be dropped by any mrcal tool that rewrites the file. The
// sidecar names the lens model, image size and intrinsics it belongs to, and reading it checks
// them against the model, so a stale sidecar (a re-calibrated camera) is refused, not used.
//
// The file: {"type": "svms.intrinsics_covariance", "lensmodel", "imagersize": [w, h],
// "intrinsics": [N], "covariance_factor": N rows of N (L, with Cov(intrinsics) = L L^T, units of
// the intrinsics), "sigma": [N] (the square roots of the diagonal, for people; not read),
// "noise_sigma_px", "views" (what the estimate rests on; informational)}, and optionally
// "mean_frames_factor" (below).
//
// mrcal's projection uncertainty. A model calibrated by mrcal's tools keeps its whole problem in
// 'optimization_inputs'; `svms camera import-uncertainty` (svms/pipelines/mrcal_uncertainty.h)
// evaluates it with mrcal's own Python and writes this sidecar. Its covariance_factor is the
// intrinsics' block of mrcal's state covariance (the marginal: what a pose measured in this
// model's camera frame needs, as for `svms calibrate`). mrcal's projection_uncertainty answers
// another question: where a point fixed to the calibration boards (their mean frame) projects,
// so an intrinsics error that the boards' poses absorb as a rigid motion of the camera does not
// count; it is often several times smaller. "mean_frames_factor" keeps what it needs: a factor
// (N + 6 rows of N + 6, lower triangular) of the joint covariance of [intrinsics (N), psi (3,
// radians), kappa (3, metres)], where the points fixed to the boards' mean frame move in the
// camera frame by d p_cam = psi x p_cam + kappa. MeanFramesProjectionCovariance evaluates it.
#pragma once

#include <Eigen/Core>
#include <string>

#include "svms/base/file_io.h"
#include "svms/base/status.h"
#include "svms/camera/camera.h"

namespace svms {

// CAMERA.cameramodel -> CAMERA.cameramodel.covariance.json
std::string CovarianceSidecarPath(const std::string& cameramodel_path);

// Writes the sidecar of `camera`, whose intrinsics_covariance_factor() must be set (error
// otherwise). noise_sigma_px and views describe the calibration (stored, informational).
// Atomic (file_io.h).
// mean_frames_factor: empty, or (N + 6) x (N + 6) and finite (written as "mean_frames_factor").
Status WriteCovarianceSidecar(const std::string& path, const CameraModel& camera,
                              double noise_sigma_px, int views,
                              const Eigen::MatrixXd& mean_frames_factor = Eigen::MatrixXd());
// The sidecar's text (what WriteCovarianceSidecar writes); `path` names it in errors.
Status CovarianceSidecarText(const std::string& path, const CameraModel& camera,
                             double noise_sigma_px, int views, std::string* text,
                             const Eigen::MatrixXd& mean_frames_factor = Eigen::MatrixXd());

// Writes the camera model at `path` and, when it has an intrinsics covariance, its sidecar,
// as a pair (AtomicFileSet): both are complete before either replaces an earlier file, and a
// failed write leaves both earlier files as they were. A camera without a covariance removes
// an earlier sidecar (it belonged to another calibration).
Status WriteCameraWithSidecar(const std::string& path, const CameraModel& camera,
                              double noise_sigma_px, int views);
// The same into a group of files that the caller commits (with other outputs); the model must
// have a covariance factor. On an error the caller must not commit the set.
Status AddCameraWithSidecar(const std::string& path, const CameraModel& camera,
                            double noise_sigma_px, int views, AtomicFileSet* files);

// Reads a sidecar and sets camera->intrinsics_covariance_factor(). Errors are one line, start
// with the path and name the field: not JSON, a missing or mistyped field, a factor of the
// wrong shape or with non-finite values, and a sidecar written for another model (lens model,
// image size or an intrinsic that differs from the camera's by more than 1e-9 of itself).
// On error *camera is unchanged.
Status ReadCovarianceSidecar(const std::string& path, CameraModel* camera);

// The sidecar's "mean_frames_factor" ((N + 6) x (N + 6), N = camera.intrinsics().size()), after
// the checks of ReadCovarianceSidecar (the sidecar must belong to `camera`). Empty (0 x 0) when
// the sidecar has none (`svms calibrate` writes none). On error *factor is unchanged.
Status ReadMeanFramesFactor(const std::string& path, const CameraModel& camera,
                            Eigen::MatrixXd* factor);

// mrcal 2.2's projection uncertainty (mrcal.projection_uncertainty, what
// mrcal-show-projection-uncertainty plots) of the point p_cam (camera frame, metres) from a
// mean_frames_factor: Cov(q) = G M M^T G^T (pixels^2), G = [dq/dintrinsics, dq/dp (-[p]x),
// dq/dp]. at_infinity: only the direction of p_cam counts and kappa is left out (mrcal's
// atinfinity=True). False when the point does not project with gradients or the factor is not
// (N + 6) x (N + 6); *covariance is then unchanged.
bool MeanFramesProjectionCovariance(const CameraModel& camera,
                                    const Eigen::MatrixXd& mean_frames_factor,
                                    const Eigen::Vector3d& p_cam, bool at_infinity,
                                    Eigen::Matrix2d* covariance);

// CameraModel::Read, then ReadCovarianceSidecar of CovarianceSidecarPath(path) when that file
// exists (an unreadable or mismatched sidecar is an error, never silently skipped). A camera
// that cannot measure (CameraModel::UnusableReason) is refused: every caller measures with it.
Status ReadCameraWithSidecar(const std::string& path, CameraModel* camera);

// The factor of a covariance block: L (n x n, lower triangular) with L L^T = F F^T for the
// rows F of a factor of the whole state's covariance (e.g. the intrinsics' rows of
// CalibrationResult::covariance_factor). PSD by construction.
Eigen::MatrixXd CompactFactor(const Eigen::MatrixXd& rows_of_factor);

}  // namespace svms
