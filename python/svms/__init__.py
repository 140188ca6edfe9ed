"""SVMS markers from Python: detection, camera models, the fused object pose.

The classes are the C++ library's (bound with pybind11 in svms._svms); docs/python.md shows them
at work. Units and frames as in docs/conventions.md: metres, radians, pixels (pixel (0, 0) is the
centre of the top-left pixel); a pose named a_from_b maps points of frame b into frame a; a 6 x 6
covariance is ordered [rotation, translation], the rotation a small angle about the axes of the
frame named first.
"""
from ._svms import (  # noqa: F401
    CalibrationResult,
    Camera,
    Detection,
    Detector,
    DetectorOptions,
    FrameResult,
    Layout,
    LayoutEntry,
    MarkerModel,
    NestedMarker,
    ObjectPose,
    ObjectPoseOptions,
    Pose,
    PoseEstimator,
    PoseEstimatorOptions,
    PostModel,
    ResponseEstimate,
    RigFrameResult,
    RigPoseEstimator,
    SurveyResult,
    SurveySummary,
    artwork_pixel_from_plane,
    calibrate,
    estimate_response,
    marker_image,
    read_layout,
    read_markers,
    survey,
)
from . import _camera

Camera.from_mrcal = staticmethod(_camera.from_mrcal)
Camera.from_opencv = staticmethod(_camera.from_opencv)
Camera.to_mrcal = _camera.to_mrcal
