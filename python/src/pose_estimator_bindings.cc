// svms.PoseEstimator: the fused object pose of one frame from every visible marker of a layout,
// with its 6 x 6 covariance (fusion/pose_estimator.h, fusion/object_pose.h).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <memory>
#include <mutex>

#include "bindings.h"
#include "detector_bindings.h"
#include "image_array.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/marker/model_io.h"

namespace svms::python {
namespace {

// The Python object behind svms.PoseEstimator. Estimate() reuses the estimator's scratch, so
// calls are serialised by `mutex` (taken with the GIL released: other Python threads run).
struct PyPoseEstimator {
  std::unique_ptr<PoseEstimator> estimator;
  std::unique_ptr<std::mutex> mutex = std::make_unique<std::mutex>();

  FrameResult Estimate(const py::array& image, double timestamp) const {
    if (!std::isfinite(timestamp))
      throw py::value_error("t: expected a finite time stamp (seconds)");
    const cv::Mat mat = MatFromArray(image);
    const CameraModel& cam = estimator->camera();
    if (mat.cols != cam.width() || mat.rows != cam.height())
      throw py::value_error("image: " + std::to_string(mat.cols) + "x" + std::to_string(mat.rows) +
                            " pixels, but the camera model is " + std::to_string(cam.width()) +
                            "x" + std::to_string(cam.height()));
    FrameResult out;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(*mutex);
      estimator->Estimate(mat, timestamp, &out);
    }
    return out;
  }
};

Layout LayoutFrom(const py::object& layout) {
  if (py::isinstance<Layout>(layout)) return layout.cast<Layout>();
  if (py::isinstance<py::str>(layout) || py::hasattr(layout, "__fspath__")) {
    return py::module_::import("svms").attr("read_layout")(layout).cast<Layout>();
  }
  throw py::type_error("layout: expected a Layout or a path to a layout JSON file, got " +
                       py::str(py::type::of(layout)).cast<std::string>());
}

// One layout, or a list (or tuple) of them: one object each.
std::vector<Layout> LayoutsFrom(const py::object& layouts) {
  if (!py::isinstance<py::list>(layouts) && !py::isinstance<py::tuple>(layouts))
    return {LayoutFrom(layouts)};
  std::vector<Layout> out;
  for (const py::handle& l : layouts)
    out.push_back(LayoutFrom(py::reinterpret_borrow<py::object>(l)));
  return out;
}

}  // namespace

void BindPoseEstimator(py::module_& m) {
  py::class_<ObjectPoseOptions>(m, "ObjectPoseOptions",
                                "The fusion's main settings (fusion/object_pose.h documents each).")
      .def(py::init<>())
      .def_readwrite("use_tips", &ObjectPoseOptions::use_tips)
      .def_readwrite("use_layout_covariance", &ObjectPoseOptions::use_layout_covariance)
      .def_readwrite("use_calibration_covariance", &ObjectPoseOptions::use_calibration_covariance)
      .def_readwrite("robust_k", &ObjectPoseOptions::robust_k)
      .def_readwrite("reject_quantile", &ObjectPoseOptions::reject_quantile)
      .def_readwrite("point_reject_sigma", &ObjectPoseOptions::point_reject_sigma)
      .def_readwrite("variance_prior_dof", &ObjectPoseOptions::variance_prior_dof)
      .def_readwrite("max_iterations", &ObjectPoseOptions::max_iterations);

  py::class_<PoseEstimatorOptions>(m, "PoseEstimatorOptions")
      .def(py::init<>())
      .def_readwrite("detector", &PoseEstimatorOptions::detector, "DetectorOptions")
      .def_readwrite("fusion", &PoseEstimatorOptions::fusion, "ObjectPoseOptions")
      .def_readwrite("budget_ms", &PoseEstimatorOptions::budget_ms,
                     "time budget per frame, milliseconds (0: none)");

  py::class_<ObjectPose>(
      m, "ObjectPose",
      "One frame's cam_from_object from every marker of the layout seen, with its 6 x 6 "
      "covariance ([rotation, translation]: a small rotation about the camera axes, radians, "
      "and the translation, metres).")
      .def_readonly("valid", &ObjectPose::valid)
      .def_readonly("cam_from_object", &ObjectPose::cam_from_object, "Pose (when valid)")
      .def_readonly("covariance", &ObjectPose::covariance, "6 x 6, rad^2 and m^2")
      .def_readonly("markers_seen", &ObjectPose::markers_seen)
      .def_readonly("markers_used", &ObjectPose::markers_used)
      .def_readonly("points_used", &ObjectPose::points_used)
      .def_readonly("points_rejected", &ObjectPose::points_rejected)
      .def_readonly("ids_used", &ObjectPose::ids_used)
      .def_readonly("ids_rejected", &ObjectPose::ids_rejected)
      .def_readonly("rms_px", &ObjectPose::rms_px, "RMS residual per coordinate, pixels")
      .def_readonly("chi2", &ObjectPose::chi2)
      .def_readonly("dof", &ObjectPose::dof)
      .def_readonly("variance_factor", &ObjectPose::variance_factor)
      .def_readonly("ambiguous", &ObjectPose::ambiguous)
      .def_readonly("alternative_cam_from_object", &ObjectPose::alternative_cam_from_object)
      .def_readonly("alternative_weight", &ObjectPose::alternative_weight)
      .def_readonly("calibration_in_covariance", &ObjectPose::calibration_in_covariance)
      .def_property_readonly(
          "bias_factor", [](const ObjectPose& p) { return Eigen::MatrixXd(p.bias_factor()); },
          "6 x k: the share of `covariance` common to every frame (the calibration's, a rig's "
          "extrinsics') is bias_factor @ bias_factor.T; column j is the same error in every "
          "frame of one estimator (k = 0 without either)")
      .def_readonly("from_marker_pose", &ObjectPose::from_marker_pose,
                    "the pose is its one marker's own, with its stripe and decal edges")
      .def_readonly("edge_rows", &ObjectPose::edge_rows,
                    "rows of the markers' edge quadratics in the fit")
      .def_readonly("extrinsics_in_covariance", &ObjectPose::extrinsics_in_covariance,
                    "a rig's: the cameras' rig_from_cam uncertainty is in the covariance")
      .def_readonly("cameras_used", &ObjectPose::cameras_used,
                    "the camera of each entry of ids_used (0 for one camera)")
      .def_readonly("poorly_conditioned", &ObjectPose::poorly_conditioned)
      .def_readonly("message", &ObjectPose::message, "why not valid")
      .def("__repr__", [](const ObjectPose& p) {
        return std::string("<svms.ObjectPose ") +
               (p.valid ? "valid, " + std::to_string(p.markers_used) + " markers"
                        : "invalid: " + p.message) +
               ">";
      });

  py::class_<FrameResult>(m, "FrameResult", "What PoseEstimator.estimate gives for one frame")
      .def_readonly("timestamp", &FrameResult::timestamp, "seconds, as given")
      .def_readonly("pose", &FrameResult::pose, "ObjectPose of the first (or only) layout")
      .def_property_readonly(
          "poses",
          [](const FrameResult& r) {
            std::vector<ObjectPose> poses;
            for (size_t i = 0; i < r.num_objects(); ++i) poses.push_back(r.object(i));
            return poses;
          },
          "list of ObjectPose, one per layout in the estimator's order (poses[0] is pose)")
      .def_readonly("detections", &FrameResult::detections,
                    "every marker found (of a layout or not), list of Detection")
      .def_readonly("unassigned_ids", &FrameResult::unassigned_ids,
                    "IDs of the detections of no layout, one per detection (empty unless the "
                    "detector reports every ID: options.detector.known_ids_only = False)")
      .def_readonly("budget_exceeded", &FrameResult::budget_exceeded)
      .def_readonly("latency_ms", &FrameResult::latency_ms,
                    "the whole call, wall clock: conversion to linear light (estimate), "
                    "detection and every layout's fusion")
      .def_readonly("detect_ms", &FrameResult::detect_ms, "the frame's one detection pass")
      .def_readonly("fuse_ms", &FrameResult::fuse_ms, "every layout's fusion together")
      .def_readonly("detection_passes", &FrameResult::detection_passes,
                    "times the detector ran for this frame: 1, whatever the number of layouts");

  py::class_<PyPoseEstimator>(
      m, "PoseEstimator",
      "The object's pose in each frame from every visible marker of a surveyed layout.\n\n"
      "PoseEstimator(camera, layout, options=None, response=None)\n"
      "  camera: a Camera or a .cameramodel path (its covariance sidecar is read: the pose "
      "covariance then includes the calibration's error)\n"
      "  layout: a Layout or a layout JSON path (svms survey's output), or a list of them: one "
      "object each, all from one detection per frame (FrameResult.poses); a marker ID in two "
      "layouts raises ValueError naming both\n"
      "  options: PoseEstimatorOptions\n"
      "  response: None when the frames are linear in light; 'srgb', 'gamma:2.2' otherwise.\n"
      "PoseEstimator.from_files(camera_path, layout_path): as `svms pose` and the C API do, "
      "with the camera's photometric file when there is one; layout_path may be a list of "
      "paths.")
      .def(py::init([](const py::object& camera, const py::object& layout,
                       const std::optional<PoseEstimatorOptions>& options,
                       const std::optional<std::string>& response) {
             const CameraModel cam = CameraFrom(camera);
             if (std::string why = cam.UnusableReason(); !why.empty())
               throw py::value_error("camera: " + why);
             PoseEstimatorOptions o = options.value_or(PoseEstimatorOptions());
             if (response) o.photometric = PhotometricFrom(response);
             auto e = std::make_unique<PyPoseEstimator>();
             RaiseIfError(PoseEstimator::Create(cam, LayoutsFrom(layout), o, &e->estimator));
             return e;
           }),
           py::arg("camera"), py::arg("layout"), py::arg("options") = py::none(),
           py::arg("response") = py::none())
      .def_static(
          "from_files",
          [](const std::filesystem::path& camera, const py::object& layout,
             const std::optional<PoseEstimatorOptions>& options) {
            RaiseIfMissing(camera.string(), "an mrcal .cameramodel file");
            const bool several =
                py::isinstance<py::list>(layout) || py::isinstance<py::tuple>(layout);
            std::vector<std::string> paths;
            for (const py::handle& l :
                 several ? py::iterable(layout) : py::iterable(py::make_tuple(layout)))
              paths.push_back(l.cast<std::filesystem::path>().string());
            for (const std::string& p : paths) RaiseIfMissing(p, "a layout JSON file");
            auto e = std::make_unique<PyPoseEstimator>();
            const PoseEstimatorOptions o = options.value_or(PoseEstimatorOptions());
            RaiseIfError(
                several
                    ? PoseEstimator::CreateFromFiles(camera.string(), paths, o, &e->estimator)
                    : PoseEstimator::CreateFromFiles(camera.string(), paths[0], o, &e->estimator));
            return e;
          },
          py::arg("camera_path"), py::arg("layout_path"), py::arg("options") = py::none())
      .def("estimate", &PyPoseEstimator::Estimate, py::arg("image"), py::arg("t") = 0.0,
           "The fused pose of one frame: `image` as for Detector.detect (no copy), `t` its time "
           "stamp (seconds, passed through). Returns a FrameResult (.pose: ObjectPose).")
      .def_property_readonly("camera",
                             [](const PyPoseEstimator& e) { return e.estimator->camera(); })
      .def_property_readonly(
          "layout", [](const PyPoseEstimator& e) { return e.estimator->layout(); },
          "the first (or only) layout")
      .def_property_readonly(
          "layouts", [](const PyPoseEstimator& e) { return e.estimator->layouts(); },
          "every layout, in the order of FrameResult.poses");
}

}  // namespace svms::python
