// The pieces of the extension module svms._svms, one concept per file: each Bind* adds its
// classes and functions to the module (module.cc calls them in dependency order).
#pragma once

#include <pybind11/pybind11.h>

#include <filesystem>
#include <string>

#include "svms/base/status.h"

namespace svms::python {

namespace py = pybind11;

void BindGeometry(py::module_& m);          // Pose
void BindCamera(py::module_& m);            // Camera
void BindMarkers(py::module_& m);           // MarkerModel, Layout, model files
void BindDetector(py::module_& m);          // Detector, Detection, DetectorOptions
void BindPoseEstimator(py::module_& m);     // PoseEstimator, ObjectPose, FrameResult
void BindRigPoseEstimator(py::module_& m);  // RigPoseEstimator, RigFrameResult
void BindArtwork(py::module_& m);           // marker artwork as arrays
void BindSurvey(py::module_& m);            // survey, SurveyResult
void BindCalibration(py::module_& m);       // calibrate, CalibrationResult

// Raises ValueError with the status' one-line message unless it is OK.
inline void RaiseIfError(const Status& s) {
  if (!s.ok()) throw py::value_error(s.message());
}

// Raises FileNotFoundError naming `path` (and what it should have been) when it does not exist:
// the library's readers report a missing file as any other error, Python programs expect OSError.
inline void RaiseIfMissing(const std::string& path, const char* what) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    PyErr_SetString(PyExc_FileNotFoundError,
                    (path + ": no such file (expected " + what + ")").c_str());
    throw py::error_already_set();
  }
}

}  // namespace svms::python
