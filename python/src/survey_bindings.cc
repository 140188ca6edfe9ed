// svms.survey: where the markers sit on an object, from images of it (bundle/survey.h), the
// same solve as `svms survey` on arrays instead of files; returns a SurveyResult.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.h"
#include "detector_bindings.h"
#include "image_list.h"
#include "svms/bundle/survey.h"
#include "svms/marker/layout.h"

namespace svms::python {
namespace {

SurveyResult Survey(const py::object& images, const py::object& camera_arg, const py::object& markers,
                    std::optional<int> reference, bool refine_intrinsics, bool drop_disconnected,
                    std::optional<double> corner_sigma, int threads,
                    const std::optional<std::vector<std::string>>& names,
                    const std::optional<std::string>& response) {
  const CameraModel camera = CameraFrom(camera_arg);
  if (std::string why = camera.UnusableReason(); !why.empty())
    throw py::value_error("camera: " + why);
  const std::vector<MarkerModel> models = MarkerModelsFrom(markers);
  if (models.empty()) throw py::value_error("markers: expected the marker models, got none");
  SurveyOptions options;
  SurveyConfig config;
  if (corner_sigma) {
    if (!(std::isfinite(*corner_sigma) && *corner_sigma > 0))
      throw py::value_error("corner_sigma: expected a positive number of pixels, got " +
                            std::to_string(*corner_sigma) + " (None: each corner's own sigma)");
    options.corner_sigma_px = *corner_sigma;
    options.corner_sigma_from_fit = false;
  }
  options.num_threads = std::max(1, threads);
  if (!reference) throw py::value_error("reference: expected the ID of the marker whose frame is the object frame");
  bool known = false;
  for (const MarkerModel& m : models) known = known || m.id == *reference || (m.inner && m.inner->id == *reference);
  if (!known)
    throw py::value_error("reference: no marker with ID " + std::to_string(*reference) +
                          " among the marker models; expected the ID of one of them");
  config.reference_id = *reference;
  config.refine_intrinsics = refine_intrinsics;
  config.drop_disconnected = drop_disconnected;
  RaiseIfError(options.Check());
  RaiseIfError(config.Check());

  std::vector<py::array> keep;
  std::vector<cv::Mat> mats = MatsFromList(images, &keep);
  if (mats.empty()) throw py::value_error("images: expected at least one image, got none");
  const std::vector<std::string> image_names = ImageNames(names, mats.size());
  const std::optional<PhotometricModel> photometric = PhotometricFrom(response);
  for (size_t i = 0; i < mats.size(); ++i) {
    if (mats[i].cols != camera.width() || mats[i].rows != camera.height())
      throw py::value_error("images[" + std::to_string(i) + "]: " + std::to_string(mats[i].cols) +
                            "x" + std::to_string(mats[i].rows) + " pixels, but the camera model is " +
                            std::to_string(camera.width()) + "x" + std::to_string(camera.height()));
    if (photometric) {  // a converted copy, in linear light
      cv::Mat linear;
      RaiseIfError(LinearizeImage(mats[i], *photometric, &linear));
      mats[i] = linear;
    }
  }
  const Detector detector(DetectorOptions{}, camera, models);
  const std::vector<std::vector<Detection>> found = DetectAll(detector, mats, threads);
  std::vector<SurveyImage> survey_images(mats.size());
  for (size_t i = 0; i < mats.size(); ++i) survey_images[i] = {image_names[i], found[i]};
  SurveyResult result;
  Status s;
  {
    py::gil_scoped_release release;
    s = RunSurvey(survey_images, models, camera, options, config, &result);
  }
  if (!s) throw py::value_error("survey: " + s.message());
  result.layout.name = result.summary.LayoutName();
  return result;
}

}  // namespace

void BindSurvey(py::module_& m) {
  py::class_<SurveySummary>(m, "SurveySummary", "How the survey went (bundle/survey_options.h)")
      .def_readonly("success", &SurveySummary::success)
      .def_readonly("message", &SurveySummary::message)
      .def_readonly("images_total", &SurveySummary::images_total)
      .def_readonly("images_used", &SurveySummary::images_used)
      .def_readonly("detections_used", &SurveySummary::detections_used)
      .def_readonly("markers_surveyed", &SurveySummary::markers_surveyed)
      .def_readonly("left_out", &SurveySummary::left_out, "(marker ID, why) of markers left out")
      .def_readonly("components", &SurveySummary::components)
      .def_readonly("rms_px", &SurveySummary::rms_px, "over all corners and tips, pixels")
      .def_readonly("variance_factor", &SurveySummary::variance_factor)
      .def_readonly("covariance_ok", &SurveySummary::covariance_ok)
      .def_readonly("calibration_in_covariance", &SurveySummary::calibration_in_covariance)
      .def_property_readonly("report", &SurveySummary::BriefReport, "a few lines for people")
      .def("__repr__", [](const SurveySummary& s) { return s.BriefReport(); });

  py::class_<SurveyResult>(m, "SurveyResult")
      .def_readonly("layout", &SurveyResult::layout,
                    "the surveyed Layout (object frame: the reference marker's), with covariances")
      .def_readonly("initial_layout", &SurveyResult::initial_layout)
      .def_readonly("image_names", &SurveyResult::image_names)
      .def_readonly("image_used", &SurveyResult::image_used)
      .def_readonly("cam_from_object", &SurveyResult::cam_from_object, "per image, Pose")
      .def_readonly("camera", &SurveyResult::camera, "with refined intrinsics when asked")
      .def_readonly("summary", &SurveyResult::summary);

  m.def("survey", &Survey, py::arg("images"), py::arg("camera"), py::arg("markers"),
        py::kw_only(), py::arg("reference") = py::none(), py::arg("refine_intrinsics") = false,
        py::arg("drop_disconnected") = false, py::arg("corner_sigma") = py::none(),
        py::arg("threads") = 1, py::arg("names") = py::none(), py::arg("response") = py::none(),
        "Surveys the markers on an object from images of it, as `svms survey` does: `images` a "
        "list of numpy arrays (as for Detector.detect, used in place), `camera` a Camera or path, "
        "`markers` the marker models (path, Layout or MarkerModel list), `reference` the ID of "
        "the marker whose frame becomes the object frame. Returns a SurveyResult (.layout: "
        "each marker's object_from_marker and 6 x 6 covariance, object axes). ValueError when "
        "the survey cannot be solved (with why).");
}

}  // namespace svms::python
