// svms.calibrate: a camera model from images of a marker board (calib/calibrate.h), the same
// two passes as `svms calibrate` (pipelines/calibration_run.cc) on arrays instead of files:
// detect with the corners fitted in pixels, calibrate, detect again through that lens model
// (the sides fitted in the undistorted plane), calibrate again. Returns a CalibrationResult.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.h"
#include "detector_bindings.h"
#include "image_list.h"
#include "svms/calib/calibrate.h"
#include "svms/calib/observations.h"
#include "svms/marker/layout.h"

namespace svms::python {
namespace {

Layout BoardFrom(const py::object& board) {
  if (py::isinstance<Layout>(board)) return board.cast<Layout>();
  if (py::isinstance<py::str>(board) || py::hasattr(board, "__fspath__"))
    return py::module_::import("svms").attr("read_layout")(board).cast<Layout>();
  throw py::type_error("board: expected a Layout or a path to a board's layout JSON, got " +
                       py::str(py::type::of(board)).cast<std::string>());
}

// The board's points seen in every image, detected with `camera` (empty: in pixels). Every ID
// is decoded, as `svms calibrate` does.
std::vector<ViewObservations> Observe(const std::vector<cv::Mat>& images,
                                      const std::vector<std::string>& names, const Layout& board,
                                      const CameraModel& camera, int threads) {
  std::vector<MarkerModel> models;
  for (const LayoutEntry& e : board.markers) models.push_back(e.marker);
  DetectorOptions options;
  options.known_ids_only = false;
  const Detector detector(options, camera, models);
  const std::vector<std::vector<Detection>> found = DetectAll(detector, images, threads);
  std::vector<ViewObservations> views;
  for (size_t i = 0; i < images.size(); ++i)
    views.push_back(ObservationsFromDetections(found[i], board, names[i],
                                               DetectorOptions().pose.corner_sigma_px));
  return views;
}

CalibrationResult Calibration(const py::object& images, const py::object& board_arg,
                              const std::string& lensmodel, bool redetect, bool board_warp,
                              bool edge_bias, int threads,
                              const std::optional<std::vector<std::string>>& names,
                              const std::optional<std::string>& response) {
  const Layout board = BoardFrom(board_arg);
  std::vector<py::array> keep;
  std::vector<cv::Mat> mats = MatsFromList(images, &keep);
  if (Status s = CheckCalibrationRequest(lensmodel, static_cast<int>(mats.size())); !s)
    throw py::value_error("lensmodel: " + s.message());
  const std::vector<std::string> image_names = ImageNames(names, mats.size());
  const std::optional<PhotometricModel> photometric = PhotometricFrom(response);
  for (size_t i = 0; i < mats.size(); ++i) {
    if (mats[i].size() != mats[0].size())
      throw py::value_error("images[" + std::to_string(i) + "]: " + std::to_string(mats[i].cols) +
                            "x" + std::to_string(mats[i].rows) + " pixels; expected " +
                            std::to_string(mats[0].cols) + "x" + std::to_string(mats[0].rows) +
                            " like the first image");
    if (photometric) {  // a converted copy, in linear light
      cv::Mat linear;
      RaiseIfError(LinearizeImage(mats[i], *photometric, &linear));
      mats[i] = linear;
    }
  }
  CalibrationOptions co;
  co.lensmodel = lensmodel;
  co.width = mats[0].cols, co.height = mats[0].rows;
  co.board_warp = board_warp;
  co.edge_bias = edge_bias;
  co.threads = std::max(1, threads);
  RaiseIfError(co.Check());
  CalibrationResult result;
  Status s;
  std::vector<ViewObservations> views = Observe(mats, image_names, board, CameraModel(), threads);
  {
    py::gil_scoped_release release;
    s = Calibrate(views, co, &result);
  }
  if (s && redetect) {
    views = Observe(mats, image_names, board, result.camera, threads);
    py::gil_scoped_release release;
    s = Calibrate(views, co, &result);
  }
  if (!s) throw py::value_error("calibration: " + s.message());
  return result;
}

}  // namespace

void BindCalibration(py::module_& m) {
  py::class_<CalibrationResult>(
      m, "CalibrationResult", "A calibrated camera and how well the board fits (calib/calibrate.h)")
      .def_readonly("camera", &CalibrationResult::camera,
                    "the Camera, with its intrinsics' covariance factor")
      .def_readonly("views", &CalibrationResult::views, "indices of the images used")
      .def_readonly("skipped", &CalibrationResult::skipped, "(image index, why) not used")
      .def_readonly("cam_from_board", &CalibrationResult::cam_from_board, "per view used, Pose")
      .def_readonly("rms_px", &CalibrationResult::rms_px, "RMS inlier residual (2-D norm), px")
      .def_readonly("worst_px", &CalibrationResult::worst_px)
      .def_readonly("sigma_px", &CalibrationResult::sigma_px, "per coordinate, px")
      .def_readonly("num_inliers", &CalibrationResult::num_inliers)
      .def_readonly("num_outliers", &CalibrationResult::num_outliers)
      .def_readonly("covariance", &CalibrationResult::covariance,
                    "covariance of the state [intrinsics (N), cam_from_board per used view (6 "
                    "each: rvec, tvec), warp (2, with board_warp), edge bias (1, with edge_bias)], "
                    "units of the parameters; the "
                    "intrinsics' block is camera.intrinsics_covariance_factor's L L^T")
      .def_readonly("noise_sigma_px", &CalibrationResult::noise_sigma_px)
      .def_readonly("edge_bias_px", &CalibrationResult::edge_bias_px,
                    "with edge_bias: every marker side's shift out of its black square, px")
      .def_readonly("edge_bias_sigma_px", &CalibrationResult::edge_bias_sigma_px,
                    "its standard deviation, px (0 without edge_bias)")
      .def_readonly("report", &CalibrationResult::report, "the final solve's one line")
      .def("__repr__", [](const CalibrationResult& r) {
        return "<svms.CalibrationResult " + r.camera.Summary() + ", RMS " +
               std::to_string(r.rms_px) + " px over " + std::to_string(r.views.size()) + " views>";
      });

  m.def("calibrate", &Calibration, py::arg("images"), py::arg("board"), py::kw_only(),
        py::arg("lensmodel") = "LENSMODEL_OPENCV8", py::arg("redetect") = true,
        py::arg("board_warp") = false, py::arg("edge_bias") = false, py::arg("threads") = 1,
        py::arg("names") = py::none(), py::arg("response") = py::none(),
        "Calibrates a camera from images of a marker board, as `svms calibrate` does: `images` "
        "a list of numpy arrays of one size (as for Detector.detect, used in place), `board` "
        "its layout (a Layout or the path of svms generate board's JSON), `lensmodel` mrcal's "
        "name, `edge_bias` also fits one shift of every marker side in pixels (what a response "
        "curve a little off leaves; `svms calibrate --edge-bias`). Returns a CalibrationResult "
        "(.camera: the Camera, with its intrinsics' "
        "uncertainty). ValueError when it cannot be solved (with why).");
}

}  // namespace svms::python
