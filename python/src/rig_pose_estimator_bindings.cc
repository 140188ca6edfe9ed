// svms.RigPoseEstimator: one fused rig_from_object from the frames of a camera rig's cameras at
// one time stamp, with its 6 x 6 covariance (fusion/rig_pose_estimator.h).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <memory>
#include <mutex>

#include "bindings.h"
#include "image_array.h"
#include "svms/fusion/rig_pose_estimator.h"

namespace svms::python {
namespace {

// The Python object behind svms.RigPoseEstimator; estimate() calls are serialised by `mutex`.
struct PyRigPoseEstimator {
  std::unique_ptr<RigPoseEstimator> estimator;
  std::unique_ptr<std::mutex> mutex = std::make_unique<std::mutex>();

  RigFrameResult Estimate(const py::list& images, double timestamp) const {
    if (!std::isfinite(timestamp))
      throw py::value_error("t: expected a finite time stamp (seconds)");
    if (images.size() != estimator->num_cameras())
      throw py::value_error("images: got " + std::to_string(images.size()) +
                            ", expected one per camera of the rig (" +
                            std::to_string(estimator->num_cameras()) + "; None for no frame)");
    std::vector<cv::Mat> frames(images.size());
    for (size_t c = 0; c < frames.size(); ++c) {
      if (images[c].is_none()) continue;
      frames[c] = MatFromArray(images[c].cast<py::array>());
      const CameraModel& cam = estimator->camera(c).camera();
      if (frames[c].cols != cam.width() || frames[c].rows != cam.height())
        throw py::value_error("images[" + std::to_string(c) +
                              "]: " + std::to_string(frames[c].cols) + "x" +
                              std::to_string(frames[c].rows) + " pixels, but camera '" +
                              estimator->rig().cameras[c].name + "' is " +
                              std::to_string(cam.width()) + "x" + std::to_string(cam.height()));
    }
    RigFrameResult out;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(*mutex);
      estimator->Estimate(frames, timestamp, &out);
    }
    return out;
  }
};

}  // namespace

void BindRigPoseEstimator(py::module_& m) {
  py::class_<RigFrameResult>(m, "RigFrameResult",
                             "What RigPoseEstimator.estimate gives for one time stamp")
      .def_readonly("timestamp", &RigFrameResult::timestamp, "seconds, as given")
      .def_readonly("pose", &RigFrameResult::pose,
                    "ObjectPose of the first (or only) layout; its cam_from_object is "
                    "rig_from_object, its covariance about the RIG axes, its cameras_used the "
                    "camera of each of ids_used")
      .def_property_readonly(
          "poses",
          [](const RigFrameResult& r) {
            std::vector<ObjectPose> poses;
            for (size_t i = 0; i < r.num_objects(); ++i) poses.push_back(r.object(i));
            return poses;
          },
          "list of ObjectPose, one per layout")
      .def_readonly("cameras", &RigFrameResult::cameras,
                    "list of FrameResult, each camera's own detections and camera-alone pose")
      .def_readonly("latency_ms", &RigFrameResult::latency_ms);

  py::class_<PyRigPoseEstimator>(
      m, "RigPoseEstimator",
      "The object's pose from every camera of a rig at one time stamp.\n\n"
      "RigPoseEstimator.from_files(rig_path, layout_path, options=None): the rig file (*.rig, "
      "docs/conventions.md) with its cameras' models; layout_path may be a list of paths.")
      .def_static(
          "from_files",
          [](const std::filesystem::path& rig, const py::object& layout,
             const std::optional<PoseEstimatorOptions>& options) {
            RaiseIfMissing(rig.string(), "a rig file (*.rig)");
            const bool several =
                py::isinstance<py::list>(layout) || py::isinstance<py::tuple>(layout);
            std::vector<std::string> paths;
            for (const py::handle& l :
                 several ? py::iterable(layout) : py::iterable(py::make_tuple(layout)))
              paths.push_back(l.cast<std::filesystem::path>().string());
            for (const std::string& p : paths) RaiseIfMissing(p, "a layout JSON file");
            auto e = std::make_unique<PyRigPoseEstimator>();
            RaiseIfError(RigPoseEstimator::CreateFromFiles(
                rig.string(), paths, options.value_or(PoseEstimatorOptions()), &e->estimator));
            return e;
          },
          py::arg("rig_path"), py::arg("layout_path"), py::arg("options") = py::none())
      .def("estimate", &PyRigPoseEstimator::Estimate, py::arg("images"), py::arg("t") = 0.0,
           "The fused rig_from_object of one time stamp: `images` one array per camera in the "
           "rig's order (None: no frame), `t` the time stamp. Returns a RigFrameResult.")
      .def_property_readonly("camera_names", [](const PyRigPoseEstimator& e) {
        std::vector<std::string> names;
        for (const RigCamera& c : e.estimator->rig().cameras) names.push_back(c.name);
        return names;
      });
}

}  // namespace svms::python
