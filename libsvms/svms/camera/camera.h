// A calibrated camera: an mrcal lens model with its intrinsics, the image size, and the
// extrinsics of an mrcal .cameramodel file. Projection and unprojection are mrcal's own
// (mrcal 2.2's C library), so every lens model mrcal reads is supported: LENSMODEL_PINHOLE,
// _STEREOGRAPHIC, _LONLAT, _LATLON, _OPENCV4/5/8/12, _CAHVOR, _CAHVORE_linearity=...,
// _SPLINED_STEREOGRAPHIC_order=..._Nx=..._Ny=..._fov_x_deg=...
//
// Frames and units as in docs/conventions.md: the camera frame has x right, y down, z forward
// (metres); pixel (0, 0) is the centre of the top-left pixel, u right, v down. The intrinsics
// are mrcal's: fx, fy, cx, cy (pixels) followed by the model's distortion parameters.
//
// mrcal's headers are not included here (svms::camera links mrcal privately).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/geometry/pose.h"

namespace svms {

class CameraModel {
 public:
  // An empty model (no lens model): Project and Unproject return false, Write fails.
  CameraModel() = default;

  // Reads an mrcal .cameramodel file (any lens model mrcal 2.2 reads; files written by mrcal's
  // Python tools included). Errors are one line, start with the path, and say what was expected
  // (a missing file, a file mrcal cannot parse, an unknown lens model, a wrong number of
  // intrinsics, non-finite values, a zero or negative image size). mrcal's parser also prints
  // its own diagnostics to stderr. On error *out is unchanged.
  static Status Read(const std::string& path, CameraModel* out);

  // Writes an mrcal .cameramodel (the layout mrcal's Python writes: a Python-literal dict with
  // 'lensmodel', 'intrinsics', 'extrinsics' = rt_cam_ref, 'imagersize'), every number with the
  // shortest decimal form that reads back to the same double, so Write then Read is exact.
  // Read by mrcal 2.2's C and Python readers (mrcal.cameramodel(path)). The file is replaced
  // atomically (file_io.h): a failed write leaves the previous file as it was.
  Status Write(const std::string& path) const;
  // The text Write writes; `path` only names the file in an error (an empty model, non-finite
  // extrinsics).
  Status ToText(const std::string& path, std::string* text) const;

  // Whether poses can be measured with this model: mrcal 2.2 can unproject it (not CAHVORE),
  // fx and fy (models with a core) are within [kMinFocalPx, kMaxFocalPx], and the image's
  // centre unprojects and projects back to itself (a wide-angle model may fail at the corners). ""
  // when usable, else why not (one line, without a file name). Checked where a camera is loaded to
  // measure with (svms detect, pose, survey; the C API), so that an absurd model is refused at
  // load instead of giving detections without poses.
  std::string UnusableReason() const;
  // No lens has a focal length below a pixel (a pixel would span more than 45 degrees), nor
  // above 1e8 pixels (a 10 m telescope with 0.1 um pixels).
  static constexpr double kMinFocalPx = 1, kMaxFocalPx = 1e8;

  // Builds a model from a lens model name in mrcal's canonical form ("LENSMODEL_PINHOLE",
  // "LENSMODEL_OPENCV8", "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100",
  // ...) and its intrinsics. Checks the name (and for splined models a configuration mrcal can
  // evaluate: order 2 or 3, Nx and Ny >= order + 1, 0 < fov_x_deg < 360), the number of
  // intrinsics (mrcal_lensmodel_num_params), that they are finite, fx and fy > 0 (models with
  // a core), and width, height > 0 (pixels). Errors start with "lensmodel", "intrinsics" or
  // "imagersize". cam_from_ref is the identity. On error *out is unchanged.
  static Status Create(const std::string& lensmodel, const std::vector<double>& intrinsics,
                       int width, int height, CameraModel* out);

  // Checks a lens model name as Create does (errors start with "lensmodel"); on success
  // *num_intrinsics (optional) is its number of intrinsics and *has_gradients (optional)
  // whether mrcal 2.2 gives its gradients (every model but CAHVORE).
  static Status CheckLensModelName(const std::string& lensmodel, int* num_intrinsics = nullptr,
                                   bool* has_gradients = nullptr);

  // A pinhole camera with focal length f (pixels, fx = fy = f) and the principal point at the
  // image centre ((width - 1) / 2, (height - 1) / 2). Requires f > 0 and a positive, finite
  // size (asserted; an invalid request gives an empty model when assertions are off).
  static CameraModel Pinhole(double f, int width, int height);

  bool empty() const { return lensmodel_.empty(); }
  const std::string& lensmodel() const { return lensmodel_; }  // mrcal's canonical name
  const std::vector<double>& intrinsics() const { return intrinsics_; }
  int width() const { return width_; }    // pixels
  int height() const { return height_; }  // pixels

  // The extrinsics stored in the .cameramodel (mrcal's rt_cam_ref: maps points of mrcal's
  // reference frame into the camera frame). Identity unless read or set. Not used by Project.
  const Pose& cam_from_ref() const { return cam_from_ref_; }
  void set_cam_from_ref(const Pose& cam_from_ref) { cam_from_ref_ = cam_from_ref; }

  // Projects a point in the camera frame (metres) to pixels with mrcal_project. Returns false
  // (outputs untouched) for an empty model, a non-finite point, a point at or behind the image
  // plane (z <= 0) of a model that cannot project behind the camera (pinhole, OpenCV, CAHVOR(E)),
  // or a non-finite result. Optional Jacobians, mrcal_project's own analytic gradients:
  //   dpx_dp          d(pixel)/d(p_cam), 2x3, pixels per metre;
  //   dpx_dintrinsics d(pixel)/d(intrinsics), 2xN, N = intrinsics().size() (resized); dense,
  //                   also for splined models (mostly zeros there: only the control points
  //                   near the point and the core are non-zero).
  // CAHVORE has no gradients in mrcal 2.2: asking for either Jacobian then returns false.
  bool Project(const Eigen::Vector3d& p_cam, Eigen::Vector2d* px,
               Eigen::Matrix<double, 2, 3>* dpx_dp = nullptr,
               Eigen::Matrix<double, 2, Eigen::Dynamic>* dpx_dintrinsics = nullptr) const;

  // Unprojects a pixel to a unit-length direction in the camera frame: Newton's method on
  // mrcal_project (its own gradients, no heap allocation), with mrcal_unproject for the rare
  // pixel where that does not converge. Returns false (output untouched) for an empty model, a
  // non-finite pixel, CAHVORE (mrcal 2.2 cannot unproject it), a direction behind a camera
  // that cannot see there, or when no solve gets back to within kUnprojectTolerancePx of the
  // pixel (pixels).
  bool Unproject(const Eigen::Vector2d& px, Eigen::Vector3d* direction) const;

  // Unproject for each pixel (the same directions, bit for bit). Returns
  // false if any pixel fails; *directions always gets px.size() entries, NaN where one failed.
  bool UnprojectMany(const std::vector<Eigen::Vector2d>& px,
                     std::vector<Eigen::Vector3d>* directions) const;

  // The uncertainty of the intrinsics when it is known (a calibration's estimate, e.g. read
  // from the sidecar `svms calibrate` writes: camera_covariance.h): a factor L, N x N with
  // N = intrinsics().size(), such that Cov(intrinsics) = L L^T (units of the intrinsics).
  // Empty (0 x 0) when unknown: then poses computed with this camera leave the calibration's
  // error out of their covariance. Not part of the .cameramodel file (Read leaves it empty).
  const Eigen::MatrixXd& intrinsics_covariance_factor() const { return intrinsics_cov_factor_; }
  // Sets the factor; an empty matrix clears it. Error (unchanged) unless it is N x N and finite.
  Status set_intrinsics_covariance_factor(const Eigen::MatrixXd& factor);

  // One line, e.g. "LENSMODEL_OPENCV8 1024x768, fx 900.0 fy 900.0" ("(empty camera model)").
  std::string Summary() const;

  // Largest accepted distance (pixels) between a pixel and the projection of its unprojection.
  static constexpr double kUnprojectTolerancePx = 1e-4;

 private:
  // Room for mrcal's parsed lens model (mrcal_lensmodel_t: the type and the configuration),
  // kept as bytes so that this header does not need mrcal's; camera.cc checks that it fits.
  static constexpr std::size_t kMrcalLensModelBytes = 16;

  std::string lensmodel_;
  std::vector<double> intrinsics_;
  int width_ = 0;
  int height_ = 0;
  Pose cam_from_ref_;
  Eigen::MatrixXd intrinsics_cov_factor_;
  alignas(8) std::array<unsigned char, kMrcalLensModelBytes> mrcal_lensmodel_{};
};

}  // namespace svms
