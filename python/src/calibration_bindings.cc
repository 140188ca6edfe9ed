// svms.calibrate: a camera model from images of a marker board (calib/calibrate.h), the same
// two passes as `svms calibrate` (pipelines/calibration_run.cc) on arrays instead of files:
// detect with the corners fitted in pixels, calibrate, detect again through that lens model
// (the sides fitted in the undistorted plane), calibrate again. Returns a CalibrationResult.
// svms.estimate_response: the camera's response curve from the same images' marker sides
// (response_estimate.h), as `svms calibrate --response estimate` estimates it.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <iterator>
#include <opencv2/imgproc.hpp>

#include "bindings.h"
#include "detector_bindings.h"
#include "image_list.h"
#include "svms/calib/calibrate.h"
#include "svms/calib/observations.h"
#include "svms/camera/photometric.h"
#include "svms/detect/response_estimate.h"
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

// *image in linear light through `model`, as `svms calibrate` reads its files: colour as
// luminance in linear light, 16-bit at full depth (LinearizeImage: an 8-bit grey image whose
// model is the identity is kept as it is). A raw frame's noise from its stored values needs a
// black level, which these calls do not take: the detector estimates it on the linear image.
void Linearize(const PhotometricModel& model, cv::Mat* image) {
  cv::Mat linear;
  RaiseIfError(LinearizeImage(*image, model, &linear));
  *image = linear;
}

// The response from the sides of the board's markers in `stored` (the arrays as given), as
// `svms calibrate --response estimate` finds it from its first pass: detected through the
// default rule's curve (8-bit images sRGB, deeper ones linear; docs/conventions.md), patches
// across the sides of every marker found (any ID), at most 25,000 in all, evenly over each
// image's markers, values normalised by the depth's range. patches = 0 where too few sides
// were usable.
ResponseEstimate EstimateResponse(const std::vector<cv::Mat>& stored, const Layout& board,
                                  int threads, size_t* collected = nullptr) {
  PhotometricModel srgb;
  srgb.response = Response::Srgb();
  std::vector<cv::Mat> provisional = stored;
  for (size_t i = 0; i < stored.size(); ++i)
    Linearize(stored[i].depth() == CV_8U ? srgb : PhotometricModel(), &provisional[i]);
  std::vector<MarkerModel> models;
  for (const LayoutEntry& e : board.markers) models.push_back(e.marker);
  DetectorOptions options;
  options.known_ids_only = false;
  const Detector detector(options, CameraModel(), models);
  const std::vector<std::vector<Detection>> found = DetectAll(detector, provisional, threads);
  py::gil_scoped_release release;
  const size_t per_image = std::max<size_t>(1, 25000 / std::max<size_t>(1, stored.size()));
  std::vector<EdgePatch> patches;
  for (size_t i = 0; i < stored.size(); ++i) {
    // One channel, as `svms calibrate` reads a colour file's stored values.
    cv::Mat grey = stored[i];
    if (stored[i].channels() == 3) cv::cvtColor(stored[i], grey, cv::COLOR_BGR2GRAY);
    std::vector<EdgePatch> mine;
    CollectEdgePatches(grey, found[i], 0, 0, &mine);
    KeepEvenly(per_image, &mine);
    std::move(mine.begin(), mine.end(), std::back_inserter(patches));
  }
  if (collected) *collected = patches.size();
  return EstimateGammaFromEdges(patches);
}

// The images' common size, or ValueError naming the first that differs.
void CheckSameSize(const std::vector<cv::Mat>& mats) {
  for (size_t i = 0; i < mats.size(); ++i)
    if (mats[i].size() != mats[0].size())
      throw py::value_error("images[" + std::to_string(i) + "]: " + std::to_string(mats[i].cols) +
                            "x" + std::to_string(mats[i].rows) + " pixels; expected " +
                            std::to_string(mats[0].cols) + "x" + std::to_string(mats[0].rows) +
                            " like the first image");
}

ResponseEstimate EstimateResponseOf(const py::object& images, const py::object& board_arg,
                                    int threads) {
  const Layout board = BoardFrom(board_arg);
  std::vector<py::array> keep;
  const std::vector<cv::Mat> mats = MatsFromList(images, &keep);
  if (mats.empty()) throw py::value_error("images: expected at least one image, got none");
  return EstimateResponse(mats, board, std::max(1, threads));
}

py::object Calibration(const py::object& images, const py::object& board_arg,
                       const std::string& lensmodel, bool redetect, bool board_warp,
                       std::optional<bool> edge_bias, int threads,
                       const std::optional<std::vector<std::string>>& names,
                       const std::optional<std::string>& response) {
  const Layout board = BoardFrom(board_arg);
  std::vector<py::array> keep;
  std::vector<cv::Mat> mats = MatsFromList(images, &keep);
  if (mats.empty()) throw py::value_error("images: expected at least one image, got none");
  if (Status s = CheckCalibrationRequest(lensmodel, static_cast<int>(mats.size())); !s)
    throw py::value_error("lensmodel: " + s.message());
  const std::vector<std::string> image_names = ImageNames(names, mats.size());
  CheckSameSize(mats);
  const bool estimating = response && *response == "estimate";
  std::optional<ResponseEstimate> estimate;
  std::optional<PhotometricModel> photometric;
  if (estimating) {
    size_t collected = 0;
    estimate = EstimateResponse(mats, board, std::max(1, threads), &collected);
    if (estimate->patches == 0)
      throw py::value_error("response: estimate: " + std::to_string(collected) +
                            " edge patches, too few with blurred edges (marker sides of 20 px "
                            "or more); expected larger markers, or give the response");
    photometric = PhotometricModel();
    photometric->response = Response::Gamma(estimate->gamma);
  } else {
    photometric = PhotometricFrom(response);
  }
  if (photometric)  // converted copies, in linear light
    for (cv::Mat& mat : mats) Linearize(*photometric, &mat);
  CalibrationOptions co;
  co.lensmodel = lensmodel;
  co.width = mats[0].cols, co.height = mats[0].rows;
  co.board_warp = board_warp;
  // As `svms calibrate --edge-bias auto`: fitted with an estimated curve, whose error shifts
  // every side alike.
  co.edge_bias = edge_bias.value_or(estimating);
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
  py::object out = py::cast(std::move(result));
  out.attr("response") = estimate ? py::cast(*estimate) : py::none();
  return out;
}

}  // namespace

void BindCalibration(py::module_& m) {
  py::class_<ResponseEstimate>(
      m, "ResponseEstimate",
      "A camera's response curve read from the blur of marker sides (response_estimate.h): "
      "linear light = stored value ** gamma, on the depth's 0..1 scale")
      .def_readonly("gamma", &ResponseEstimate::gamma)
      .def_readonly("sigma", &ResponseEstimate::sigma,
                    "gamma's standard error, from its spread over 8 groups of the markers")
      .def_readonly("patches", &ResponseEstimate::patches,
                    "edge patches it rests on (0: too few usable sides, gamma 1)")
      .def_readonly("asymmetry", &ResponseEstimate::asymmetry,
                    "the edges' pooled skewness at gamma (near 0 when the curve fits)")
      .def_readonly("asymmetry_linear", &ResponseEstimate::asymmetry_linear,
                    "the same, read as linear")
      .def_readonly("asymmetry_srgb", &ResponseEstimate::asymmetry_srgb, "the same, read as sRGB")
      .def_property_readonly(
          "response",
          [](const ResponseEstimate& e) -> std::optional<std::string> {
            if (e.patches == 0) return std::nullopt;
            return Response::Gamma(e.gamma).Name();
          },
          "the curve as the response= arguments take it ('gamma:G'); None without an estimate "
          "(patches 0), never a curve the pixels did not give")
      .def("__repr__", [](const ResponseEstimate& e) {
        return "<svms.ResponseEstimate gamma " + std::to_string(e.gamma) + " +- " +
               std::to_string(e.sigma) + " from " + std::to_string(e.patches) + " patches>";
      });

  m.def("estimate_response", &EstimateResponseOf, py::arg("images"), py::arg("board"),
        py::kw_only(), py::arg("threads") = 1,
        "The camera's response curve from images of a marker board (or any images of SVMS "
        "markers of 20 px sides or more), as `svms calibrate --response estimate` estimates it: "
        "edges are symmetric only in linear light, and the gamma that makes the markers' sides "
        "symmetric is returned with its standard error (a ResponseEstimate; pass its .response "
        "to the response= arguments). `images`: numpy arrays as the camera stored them, 8 or 16 "
        "bits, full range (no black level), used in place: not to be changed while it runs. "
        "Only marker sides of 20 px or more with blurred edges give patches; printed artwork or "
        "unblurred edges say nothing: patches 0 and .response None.");

  py::class_<CalibrationResult>(
      m, "CalibrationResult",
      "A calibrated camera and how well the board fits (calib/calibrate.h); .response: the "
      "ResponseEstimate when calibrate estimated the curve, else None",
      py::dynamic_attr())
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
        py::arg("board_warp") = false, py::arg("edge_bias") = py::none(), py::arg("threads") = 1,
        py::arg("names") = py::none(), py::arg("response") = py::none(),
        "Calibrates a camera from images of a marker board, as `svms calibrate` does: `images` "
        "a list of numpy arrays of one size (as for Detector.detect, used in place), `board` "
        "its layout (a Layout or the path of svms generate board's JSON), `lensmodel` mrcal's "
        "name, `edge_bias` also fits one shift of every marker side in pixels (what a response "
        "curve a little off leaves; `svms calibrate --edge-bias`; None: only with an estimated "
        "curve), `response` the images' curve (None: linear; 'srgb', 'gamma:G', or 'estimate': "
        "estimate_response's, from the same images, then in .response). Returns a "
        "CalibrationResult "
        "(.camera: the Camera, with its intrinsics' "
        "uncertainty). ValueError when it cannot be solved (with why).");
}

}  // namespace svms::python
