// svms.RigPoseEstimator: one fused rig_from_object from the frames of a camera rig's cameras at
// one time stamp, with its 6 x 6 covariance (fusion/rig_pose_estimator.h).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "bindings.h"
#include "image_array.h"
#include "svms/bundle/rig_survey.h"
#include "svms/fusion/rig_pose_estimator.h"

namespace svms::python {
namespace {

// The Python object behind svms.RigPoseEstimator; estimate() calls are serialised by `mutex`.
struct PyRigPoseEstimator {
  std::unique_ptr<RigPoseEstimator> estimator;
  std::unique_ptr<std::mutex> mutex = std::make_unique<std::mutex>();

  // One time stamp's images, one per camera (None: no frame), as frames for the estimator;
  // their arrays are appended to *keep, which must outlive the frames (an argument that is not
  // already an ndarray is converted into a new one). `where` names the list in errors.
  std::vector<cv::Mat> Frames(const py::handle& images, const std::string& where,
                              std::vector<py::array>* keep) const {
    py::list list;
    try {
      list = py::reinterpret_borrow<py::object>(images).cast<py::list>();
    } catch (const py::cast_error&) {
      throw py::value_error(where + ": expected a list of images, one per camera of the rig");
    }
    const size_t n = estimator->num_cameras();
    if (list.size() != n)
      throw py::value_error(where + ": " + std::to_string(list.size()) +
                            " images, expected one per camera of the rig (" + std::to_string(n) +
                            "; None for no frame)");
    std::vector<cv::Mat> frames(n);
    for (size_t c = 0; c < n; ++c) {
      if (list[c].is_none()) continue;
      const std::string what = where + "[" + std::to_string(c) + "]";
      try {
        keep->push_back(list[c].cast<py::array>());
      } catch (const py::cast_error&) {
        throw py::value_error(what + ": expected a numpy array or None");
      }
      frames[c] = MatFromArray(keep->back(), what.c_str());
      const CameraModel& cam = estimator->camera(c).camera();
      if (frames[c].cols != cam.width() || frames[c].rows != cam.height())
        throw py::value_error(what + ": " + std::to_string(frames[c].cols) + "x" +
                              std::to_string(frames[c].rows) + " pixels, but camera '" +
                              estimator->rig().cameras[c].name + "' is " +
                              std::to_string(cam.width()) + "x" + std::to_string(cam.height()));
    }
    return frames;
  }

  RigFrameResult Estimate(const py::list& images, double timestamp) const {
    if (!std::isfinite(timestamp))
      throw py::value_error("t: expected a finite time stamp (seconds)");
    std::vector<py::array> keep;
    const std::vector<cv::Mat> frames = Frames(images, "images", &keep);
    RigFrameResult out;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(*mutex);
      estimator->Estimate(frames, timestamp, &out);
    }
    return out;
  }

  // The rig's extrinsics surveyed from `frames` (bundle/rig_survey.h; `svms survey rig` on
  // arrays): each entry (t, [image per camera or None]); `reference` the camera held fixed (its
  // index or name). Returns a dict (see the binding's docstring).
  py::dict SurveyExtrinsics(const py::list& frames, const py::object& reference) const {
    const size_t n = estimator->num_cameras();
    RigSurveyOptions survey;
    survey.measurement = estimator->options().fusion;
    for (const RigCamera& c : estimator->rig().cameras) survey.camera_names.push_back(c.name);
    if (py::isinstance<py::str>(reference)) {
      if (Status s = FindRigCamera(estimator->rig(), reference.cast<std::string>(), "the rig",
                                   &survey.reference_camera);
          !s)
        throw py::value_error("reference: " + s.message());
    } else {
      try {
        survey.reference_camera = reference.cast<int>();
      } catch (const py::cast_error&) {
        throw py::value_error("reference: expected a camera's index or name");
      }
      if (survey.reference_camera < 0 || survey.reference_camera >= static_cast<int>(n))
        throw py::value_error("reference: camera index " + std::to_string(survey.reference_camera) +
                              " is not in the rig (0 to " + std::to_string(n - 1) + ")");
    }
    // Every frame checked and converted first (Estimate's checks), then detected without the GIL.
    std::vector<std::vector<cv::Mat>> images;
    std::vector<double> timestamps;
    std::vector<py::array> keep;
    for (size_t i = 0; i < frames.size(); ++i) {
      const std::string where = "frames[" + std::to_string(i) + "]";
      py::tuple entry;
      try {
        entry = frames[i].cast<py::tuple>();
      } catch (const py::cast_error&) {
        throw py::value_error(where + ": expected a (t, [image per camera]) pair");
      }
      if (entry.size() != 2)
        throw py::value_error(where + ": expected a (t, [image per camera]) pair");
      double t;
      try {
        t = entry[0].cast<double>();
      } catch (const py::cast_error&) {
        throw py::value_error(where + "[0]: expected a time stamp (seconds)");
      }
      if (!std::isfinite(t)) throw py::value_error(where + ": expected a finite time stamp");
      std::vector<cv::Mat> mats = Frames(entry[1], where + "[1]", &keep);
      images.push_back(std::move(mats));
      timestamps.push_back(t);
    }
    if (images.empty()) throw py::value_error("frames: expected at least one time stamp, got none");
    RigSurveyResult result;
    Status status;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(*mutex);
      std::vector<RigSurveyFrame> observed;
      for (size_t i = 0; i < images.size(); ++i)
        observed.push_back(RigSurveyFrameFromImages(*estimator, images[i], timestamps[i]));
      status = SurveyRig(RigSurveyViews(*estimator), observed, survey, &result);
    }
    if (!status.ok()) throw std::runtime_error(status.message());
    py::list cameras;
    for (size_t c = 0; c < n; ++c) {
      const RigSurveyCamera& k = result.cameras[c];
      py::dict d;
      d["name"] = survey.camera_names[c];
      d["rig_from_cam"] = k.rig_from_cam;
      d["covariance"] = k.covariance ? py::cast(Eigen::MatrixXd(*k.covariance)) : py::none();
      d["reference"] = k.reference;
      d["frames"] = k.frames;
      d["markers"] = k.markers;
      d["points"] = k.points;
      d["points_rejected"] = k.points_rejected;
      d["rms_px"] = k.rms_px;
      d["rms_normalised"] = k.rms_normalised;
      cameras.append(d);
    }
    py::dict out;
    out["cameras"] = cameras;
    out["frames_used"] = result.summary.frames_used;
    out["chi2"] = result.summary.chi2;
    out["dof"] = result.summary.dof;
    out["noise_variance_factor"] = result.summary.noise_variance_factor;
    out["layout_in_covariance"] = result.summary.layout_in_covariance;
    out["calibration_in_covariance"] = result.summary.calibration_in_covariance;
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
      .def("survey_extrinsics", &PyRigPoseEstimator::SurveyExtrinsics, py::arg("frames"),
           py::arg("reference") = 0,
           "The rig's extrinsics surveyed from frames of this estimator's (first) layout, as "
           "`svms survey rig` does (bundle/rig_survey.h): `frames` a list of (t, [image per "
           "camera in the rig's order, None for no frame]); `reference` the camera held fixed "
           "(index or name). Returns a dict: cameras (per camera: name, rig_from_cam (Pose), "
           "covariance (6 x 6 [rotation about the rig axes, translation], None for a reference "
           "camera without one), reference, frames, markers, points, points_rejected, rms_px, "
           "rms_normalised), frames_used, chi2, dof, noise_variance_factor, "
           "layout_in_covariance, calibration_in_covariance. Raises ValueError naming the frame "
           "or camera for bad input, RuntimeError when the solve fails (e.g. a camera that "
           "shares no time stamp with the reference).")
      .def_property_readonly("camera_names", [](const PyRigPoseEstimator& e) {
        std::vector<std::string> names;
        for (const RigCamera& c : e.estimator->rig().cameras) names.push_back(c.name);
        return names;
      });
}

}  // namespace svms::python
