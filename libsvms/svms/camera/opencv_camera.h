// OpenCV camera files: the intrinsics that cv::calibrateCamera gives (a camera matrix K, the
// distortion coefficients, the image size), read from and written to OpenCV's cv::FileStorage
// files (YAML, XML, JSON), as mrcal lens models.
//
// OpenCV's pinhole model with distortion (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]) is
// exactly mrcal's LENSMODEL_OPENCV4 / 5 / 8 / 12: the same formula, the same coefficients in
// the same order after fx, fy, cx, cy. No distortion (no coefficients, or all zero) is
// LENSMODEL_PINHOLE: the same projection as OPENCV4 with zeros, and what mrcal's own tools
// expect of a distortion-free camera (rectified images); it also projects faster here. What
// mrcal 2.2 has no model for is refused: a skewed K (K[0][1] != 0), the tilted sensor
// (14 coefficients with tx or ty not zero; zeros are read as OPENCV12), and cv::fisheye's
// Kannala-Brandt model (declared by `distortion_model: equidistant` or `fisheye`; a list of 4
// coefficients without that declaration is k1 k2 p1 p2, cv::calibrateCamera's meaning).
//
// The fields read (the first present of each): the camera matrix `camera_matrix`,
// `cameraMatrix` or `K`; the distortion `distortion_coefficients`, `distCoeffs`, `dist_coeffs`
// or `D`; the image size `image_width` and `image_height`, or `imageSize` / `image_size`
// ([width, height]). Each may be an OpenCV matrix (!!opencv-matrix), a sequence of numbers, or a
// ROS-style map {rows, cols, data}. ROS's camera_calibration_parsers YAML (no %YAML:1.0 line,
// `distortion_model: plumb_bob | rational_polynomial | equidistant`) is read too: cv::FileStorage
// needs the directive, so it is supplied. docs/conventions.md ("OpenCV cameras") has the table.
//
// Pixels and frames are the same in both (docs/conventions.md): OpenCV's cx, cy are in the
// same pixel-centre convention as mrcal's (pixel (0, 0) is the centre of the top-left pixel).
#pragma once

#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"

namespace svms {

// The contents of an OpenCV camera file, in OpenCV's terms.
struct OpenCvCamera {
  double K[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 1}};  // pixels
  std::vector<double> dist;                             // OpenCV's order, 0 to 14 values
  bool fisheye = false;  // cv::fisheye (Kannala-Brandt): dist is k1..k4
  int width = 0, height = 0;  // pixels; 0 when the file has no image size
};

// The mrcal lens model and intrinsics of an OpenCV camera (the mapping above). Errors (one
// line, naming the field and what mrcal can represent): a skewed or malformed K, a number of
// distortion coefficients other than 0, 4, 5, 8, 12 or 14, a tilt, a fisheye model, a
// missing image size (the message suggests --image-size WxH), non-finite values.
Status CameraFromOpenCv(const OpenCvCamera& cv_camera, CameraModel* out);

// The OpenCV camera of an mrcal model: LENSMODEL_PINHOLE (5 zero coefficients, as
// cv::calibrateCamera's default), LENSMODEL_OPENCV4/5/8/12. Any other lens model is an error
// that names it. The extrinsics are not part of an OpenCV camera and are dropped.
Status OpenCvFromCamera(const CameraModel& camera, OpenCvCamera* out);

// Reads an OpenCV camera file with cv::FileStorage (the fields above). `width` and `height`,
// when positive, give the image size for a file that has none (and must agree with one that
// has). Errors are one line: the path, the field, what was expected.
Status ReadOpenCvCameraFile(const std::string& path, int width, int height, OpenCvCamera* out);

// ReadOpenCvCameraFile, then CameraFromOpenCv (errors prefixed by the path).
Status ImportOpenCvCamera(const std::string& path, int width, int height, CameraModel* out);

// The text of an OpenCV camera file for `camera` as cv::FileStorage writes it (every number
// with 17 significant digits, so that reading it back is exact): `image_width`,
// `image_height`, `camera_matrix` (3x3), `distortion_coefficients` (1xN), and a comment
// naming the mrcal lens model. XML when `path` ends in .xml, JSON for .json, else YAML
// (%YAML:1.0). `path` names the file in errors.
Status OpenCvCameraText(const std::string& path, const CameraModel& camera, std::string* text);

// Writes OpenCvCameraText atomically (file_io.h).
Status WriteOpenCvCameraFile(const std::string& path, const CameraModel& camera);

// Whether a camera file looks like an OpenCV camera file rather than an mrcal model: its name
// ends in .yml, .yaml or .xml (any case), or its text starts with "%YAML" or "<?xml". Used to
// point users at `svms camera import` instead of mrcal's parser error.
bool LooksLikeOpenCvCameraFile(const std::string& path, const std::string& text);

}  // namespace svms
