// A camera rig: several cameras rigidly mounted on one body (a docking vehicle's narrow and
// wide cameras, or a ring of cameras around its docking port), each with its lens model and its
// pose on the rig. The rig frame is the body's; a camera's pose is rig_from_cam (maps camera
// points, metres, into the rig frame), optionally with its uncertainty as a 6x6 covariance
// [rotation, translation]: the rotation a small angle about the RIG axes (radians), the
// translation in metres, rig_from_cam_true = exp([d_rot]) R, t + d_trans.
//
// The rig file (*.rig, JSON; docs/conventions.md "Camera rigs"):
//   {"type": "svms.rig", "name": "...",
//    "cameras": [{"name": "narrow", "cameramodel": "narrow.cameramodel",
//                 "rig_from_cam": {"rvec": [3], "tvec": [3]},
//                 "covariance": [[6 numbers] x 6]}, ...]}
// A camera's cameramodel path is relative to the rig file's folder (an absolute path is kept);
// its covariance sidecar is read with it (ReadCameraWithSidecar).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"
#include "svms/geometry/pose.h"

namespace svms {

struct RigCamera {
  std::string name;                   // unique in the rig
  std::string cameramodel_path;       // as resolved (rig folder / the file's path)
  bool cameramodel_absolute = false;  // the rig file gave an absolute path
  CameraModel camera;
  Pose rig_from_cam;
  std::optional<PoseCovariance> rig_from_cam_covariance;  // rig axes, [rotation, translation]
};

struct CameraRig {
  std::string name;
  std::vector<RigCamera> cameras;  // at least one
};

// The index of the rig's camera named `name` into *index; where none is, an error "no camera
// named 'NAME' in RIG (it has a, b)", RIG being `rig_label` (the rig file, or "the rig").
// Shared by every place a user names a camera.
Status FindRigCamera(const CameraRig& rig, const std::string& name, const std::string& rig_label,
                     int* index);

// Parses a rig file's text (`source` names it in errors) without reading the camera models:
// every camera's name, cameramodel path (resolved against base_dir), pose and covariance.
// Errors are one line, "<source>: cameras[1].covariance: expected ...".
Status ParseRig(const std::string& text, const std::string& source, const std::string& base_dir,
                CameraRig* rig);
// Reads a rig file and every camera model it names (with their covariance sidecars). Errors
// name the rig file and the field, and for a camera model that cannot be read, that file.
Status ReadRigFile(const std::string& path, CameraRig* rig);

// The rig file's text for `rig` (ParseRig reads it back to the same poses and covariances, to
// the last bit): each camera's name, its cameramodel path relative to `dir` (the folder the file
// is written to; absolute where the rig file read gave it so, cameramodel_absolute),
// rig_from_cam and, when it has one, its covariance (6 rows).
std::string RigToJson(const CameraRig& rig, const std::string& dir);
// Writes RigToJson(rig, PATH's folder) to `path` atomically (file_io.h).
Status WriteRigFile(const std::string& path, const CameraRig& rig);

}  // namespace svms
