// What several bindings take from Python: marker models, cameras, responses.
#pragma once

#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <vector>

#include "svms/camera/camera.h"
#include "svms/camera/photometric.h"
#include "svms/marker/marker_model.h"

namespace svms::python {

namespace py = pybind11;

// Marker models from what a Python caller gives: None (none), a path (str or os.PathLike) to a
// model file, a Layout (its markers), or an iterable of MarkerModel. TypeError otherwise.
std::vector<MarkerModel> MarkerModelsFrom(const py::object& markers);

// A camera from a Camera or a path to a .cameramodel (read as svms.Camera(path) does). TypeError
// otherwise.
CameraModel CameraFrom(const py::object& camera);

// The photometric model of `response` ("linear", "srgb", "gamma:G"; None: the frames are linear
// already), ValueError naming the text otherwise.
std::optional<PhotometricModel> PhotometricFrom(const std::optional<std::string>& response);

}  // namespace svms::python
