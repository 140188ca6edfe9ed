// svms.Detector and svms.Detection: every marker in one image (detect/detector.h), from a numpy
// array without copying it, with the GIL released while the detector runs.
#include "detector_bindings.h"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <memory>

#include "bindings.h"
#include "image_array.h"
#include "svms/camera/camera.h"
#include "svms/detect/detector.h"
#include "svms/marker/layout.h"
#include "svms/marker/model_io.h"

namespace svms::python {
namespace {

using Corners = Eigen::Matrix<double, 4, 2, Eigen::RowMajor>;

Corners CornersOf(const Detection& d) {
  Corners c;
  for (int k = 0; k < 4; ++k) c.row(k) = d.corners[k].transpose();
  return c;
}

// The Python object behind svms.Detector: the C++ detector and what it was made from.
struct PyDetector {
  CameraModel camera;
  std::optional<PhotometricModel> photometric;
  std::unique_ptr<Detector> detector;

  std::vector<Detection> Detect(const py::array& image) const {
    cv::Mat mat = MatFromArray(image);
    if (!camera.empty() && (mat.cols != camera.width() || mat.rows != camera.height()))
      throw py::value_error("image: " + std::to_string(mat.cols) + "x" + std::to_string(mat.rows) +
                            " pixels, but the camera model is " + std::to_string(camera.width()) +
                            "x" + std::to_string(camera.height()));
    std::vector<Detection> found;
    Status status;
    {
      // `image` (held by the caller's frame) keeps the pixels alive while the GIL is released.
      py::gil_scoped_release release;
      if (photometric && !photometric->IsIdentity(mat.depth() == CV_8U ? 255 : 65535)) {
        cv::Mat linear;
        // A raw frame's noise from its stored values, as svms detect takes it (noise_model.h).
        NoiseModel noise;
        const bool have_noise = EstimateStoredNoise(
            mat, *photometric, std::chrono::steady_clock::time_point::max(), &noise);
        status = LinearizeImage(mat, *photometric, &linear);
        if (status.ok())
          detector->Detect(linear, nullptr, std::chrono::steady_clock::time_point::max(), &found,
                           have_noise ? &noise : nullptr);
      } else {
        found = detector->Detect(mat);
      }
    }
    if (!status.ok()) throw py::value_error("image: " + status.message());
    return found;
  }
};

}  // namespace

std::vector<MarkerModel> MarkerModelsFrom(const py::object& markers) {
  if (markers.is_none()) return {};
  if (py::isinstance<py::str>(markers) || py::hasattr(markers, "__fspath__")) {
    const std::string p = py::str(py::module_::import("os").attr("fspath")(markers));
    RaiseIfMissing(p, "a marker model, marker set or layout JSON file");
    ModelFile f;
    RaiseIfError(ReadModelFile(p, &f));
    return f.markers;
  }
  if (py::isinstance<Layout>(markers)) {
    std::vector<MarkerModel> out;
    for (const LayoutEntry& e : markers.cast<const Layout&>().markers) out.push_back(e.marker);
    return out;
  }
  if (py::isinstance<MarkerModel>(markers)) return {markers.cast<MarkerModel>()};
  std::vector<MarkerModel> out;
  try {
    for (py::handle h : markers) out.push_back(h.cast<MarkerModel>());
  } catch (const py::cast_error&) {
    throw py::type_error(
        "markers: expected None, a path to a model file, a Layout, or MarkerModel objects, got " +
        py::str(py::type::of(markers)).cast<std::string>());
  }
  for (const MarkerModel& mm : out)
    RaiseIfError(mm.Validate("markers: ID " + std::to_string(mm.id) + ": "));
  return out;
}

CameraModel CameraFrom(const py::object& camera) {
  if (py::isinstance<CameraModel>(camera)) return camera.cast<CameraModel>();
  if (py::isinstance<py::str>(camera) || py::hasattr(camera, "__fspath__")) {
    return py::module_::import("svms").attr("Camera")(camera).cast<CameraModel>();
  }
  throw py::type_error("camera: expected a Camera or a path to a .cameramodel, got " +
                       py::str(py::type::of(camera)).cast<std::string>());
}

std::optional<PhotometricModel> PhotometricFrom(const std::optional<std::string>& response) {
  if (!response) return std::nullopt;
  PhotometricModel p;
  if (Status s = Response::Parse(*response, &p.response); !s)
    throw py::value_error("response: " + s.message());
  return p;
}

void BindDetector(py::module_& m) {
  py::class_<Detection>(
      m, "Detection",
      "One marker found in an image. Pixels as in docs/conventions.md ((0, 0) is the centre of "
      "the top-left pixel); poses in the camera frame; covariances [rotation, translation], the "
      "rotation a small angle about the camera axes (rad^2, m^2).")
      .def_readonly("id", &Detection::id)
      .def_readonly("rotation", &Detection::rotation,
                    "which marker corner the quad's first corner was (0-3)")
      .def_readonly("bit_errors", &Detection::bit_errors, "corrected bits")
      .def_property_readonly("corners", &CornersOf,
                             "the black square's corners, 4 x 2 pixels: TL, TR, BR, BL as printed")
      .def_property_readonly(
          "corner_sigma", [](const Detection& d) { return Eigen::Vector4d(d.corner_sigma.data()); },
          "each corner's standard deviation from its line fits, per axis (pixels; 0: unknown), "
          "shape (4,)")
      .def_property_readonly(
          "corner_covariance",
          [](const Detection& d) -> Eigen::Matrix<double, 8, 8> { return d.corner_covariance; },
          "the corners' joint covariance from the same line fits, 8 x 8 pixels^2 over "
          "(x0, y0, ..., x3, y3); corners on one side correlate across it (zero: unknown)")
      .def_property_readonly(
          "tip",
          [](const Detection& d) -> std::optional<Eigen::Vector2d> {
            if (!d.tip) return std::nullopt;
            return d.tip->pixel;
          },
          "the post tip's pixel (2,), or None")
      .def_property_readonly(
          "tip_sigma",
          [](const Detection& d) -> std::optional<double> {
            if (!d.tip) return std::nullopt;
            return d.tip->sigma_px;
          },
          "the tip's standard deviation per axis (pixels), or None")
      .def_readonly("cam_from_marker", &Detection::cam_from_marker,
                    "Pose (with a camera and the marker's model), or None")
      .def_readonly("covariance", &Detection::covariance,
                    "6 x 6 covariance of cam_from_marker ([rotation, translation], camera axes)")
      .def_readonly("pose_ambiguous", &Detection::pose_ambiguous,
                    "the two planar poses could not be told apart")
      .def_readonly("alternative_pose", &Detection::alternative_pose,
                    "where pose_ambiguous: the other planar pose, or None")
      .def_readonly("alternative_weight", &Detection::alternative_weight,
                    "the alternative's share of the likelihood")
      .def_readonly("calibration_in_covariance", &Detection::calibration_in_covariance,
                    "the covariance includes the camera calibration's uncertainty")
      .def_readonly("pose_rms_px", &Detection::pose_rms_px)
      .def_readonly("edge_points", &Detection::edge_points)
      .def_readonly("pose_error", &Detection::pose_error,
                    "with a camera and the marker's model but no pose: why ('' otherwise)")
      .def_readonly("nested_in", &Detection::nested_in,
                    "the outer marker's ID for a dual marker's inner marker, else -1")
      .def_readonly("black", &Detection::black, "grey level of the black square")
      .def_readonly("white", &Detection::white, "grey level of the white stripe")
      .def_property_readonly("side_px", &Detection::side_px, "the square's mean side, pixels")
      .def("__repr__", [](const Detection& d) {
        return "<svms.Detection id " + std::to_string(d.id) + (d.cam_from_marker ? ", pose" : "") +
               ">";
      });

  py::class_<DetectorOptions>(m, "DetectorOptions",
                              "The detector's main settings (detect/detector.h documents each).")
      .def(py::init<>())
      .def_readwrite("max_corrections", &DetectorOptions::max_corrections)
      .def_readwrite("max_unsupported_corrections", &DetectorOptions::max_unsupported_corrections)
      .def_readwrite("id_count", &DetectorOptions::id_count)
      .def_readwrite("known_ids_only", &DetectorOptions::known_ids_only)
      .def_readwrite("min_contrast", &DetectorOptions::min_contrast)
      .def_readwrite("refine_corners", &DetectorOptions::refine_corners)
      .def_readwrite("equalize_rings", &DetectorOptions::equalize_rings)
      .def_readwrite("deconvolve_rings", &DetectorOptions::deconvolve_rings)
      .def_readwrite("post_silhouette_margin_px", &DetectorOptions::post_silhouette_margin_px)
      .def_readwrite("threads", &DetectorOptions::threads)
      .def_property(
          "decimate", [](const DetectorOptions& o) { return o.decimate; },
          [](DetectorOptions& o, int n) {
            if (n < 1 || n > kMaxDecimate)
              throw py::value_error("DetectorOptions.decimate: " + std::to_string(n) +
                                    "; expected 1 to " + std::to_string(kMaxDecimate));
            o.decimate = n;
          });

  py::class_<PyDetector>(
      m, "Detector",
      "Finds every SVMS marker in an image, on its own (no state between images).\n\n"
      "Detector(camera=None, markers=None, options=None, response=None)\n"
      "  camera: a Camera (enables undistorted corner fits and, with markers, poses)\n"
      "  markers: a model file path, a Layout, or MarkerModel objects (each ID's size and post)\n"
      "  options: DetectorOptions\n"
      "  response: None when the images are linear in light (a machine-vision camera's raw "
      "output, svms render's PNGs); 'srgb' or 'gamma:2.2' for gamma-encoded images (each image "
      "is then converted to linear light first, in a new buffer).")
      .def(py::init([](const std::optional<CameraModel>& camera, const py::object& markers,
                       const std::optional<DetectorOptions>& options,
                       const std::optional<std::string>& response) {
             auto d = std::make_unique<PyDetector>();
             if (camera) {
               if (std::string why = camera->UnusableReason(); !why.empty())
                 throw py::value_error("camera: " + why);
               d->camera = *camera;
             }
             d->photometric = PhotometricFrom(response);
             d->detector = std::make_unique<Detector>(options.value_or(DetectorOptions()),
                                                      d->camera, MarkerModelsFrom(markers));
             return d;
           }),
           py::arg("camera") = py::none(), py::arg("markers") = py::none(),
           py::arg("options") = py::none(), py::arg("response") = py::none())
      .def("detect", &PyDetector::Detect, py::arg("image"),
           "All markers in `image`: a numpy array of H x W uint8 or uint16 (grey) or H x W x 3 "
           "(BGR, turned to grey with OpenCV's weights), used in place without a copy (rows must "
           "hold adjacent pixels: a C-contiguous array or a rectangular view of one; TypeError "
           "otherwise). Its size must be the camera's. Returns a list of Detection. The GIL is "
           "released while it runs: threads may share one Detector; do not change the array "
           "meanwhile.")
      .def_property_readonly("camera",
                             [](const PyDetector& d) -> std::optional<CameraModel> {
                               if (d.camera.empty()) return std::nullopt;
                               return d.camera;
                             })
      .def_property_readonly("options", [](const PyDetector& d) { return d.detector->options(); });

  m.def(
      "_image_address",
      [](const py::array& image) {
        return reinterpret_cast<std::uintptr_t>(MatFromArray(image).data);
      },
      py::arg("image"),
      "The address of the pixels Detector.detect reads for `image` (for tests: the array's own)");
}

}  // namespace svms::python
