// The extension module svms._svms; the package svms (python/svms/__init__.py) re-exports it.
#include <pybind11/pybind11.h>

#include "bindings.h"

PYBIND11_MODULE(_svms, m) {
  m.doc() =
      "SVMS markers: detection, camera models, fused object pose (C++ library bindings; "
      "docs/python.md)";
  namespace sp = svms::python;
  sp::BindGeometry(m);
  sp::BindCamera(m);
  sp::BindMarkers(m);
  sp::BindDetector(m);
  sp::BindPoseEstimator(m);
  sp::BindRigPoseEstimator(m);
  sp::BindArtwork(m);
  sp::BindSurvey(m);
  sp::BindCalibration(m);
}
