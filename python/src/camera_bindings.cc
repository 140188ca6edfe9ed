// svms.Camera: a calibrated camera (an mrcal lens model, its intrinsics, the image size), with
// mrcal's own projection (camera/camera.h). The constructors from mrcal.cameramodel objects and
// from OpenCV's K and distortion are in python/svms/_camera.py.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <limits>

#include "bindings.h"
#include "svms/camera/camera.h"
#include "svms/camera/camera_covariance.h"
#include "svms/camera/opencv_camera.h"

namespace svms::python {
namespace {

using Points = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Reads an mrcal .cameramodel and, when CAMERA.covariance.json exists beside it, its
// intrinsics' covariance (camera_covariance.h).
CameraModel ReadCamera(const std::filesystem::path& path, bool sidecar) {
  const std::string p = path.string();
  RaiseIfMissing(p, "an mrcal .cameramodel file");
  CameraModel c;
  RaiseIfError(CameraModel::Read(p, &c));
  const std::string side = CovarianceSidecarPath(p);
  std::error_code ec;
  if (sidecar && std::filesystem::exists(side, ec)) RaiseIfError(ReadCovarianceSidecar(side, &c));
  return c;
}

// The rows of `a` of `width` numbers each: (width,) is one row, (N, width) N rows.
py::ssize_t Rows(const Points& a, int width, const char* what) {
  if (a.ndim() == 1 && a.shape(0) == width) return 1;
  if (a.ndim() == 2 && a.shape(1) == width) return a.shape(0);
  std::string shape = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  shape += a.ndim() == 1 ? ",)" : ")";
  throw py::value_error(std::string(what) + ": expected shape (" + std::to_string(width) +
                        ",) or (N, " + std::to_string(width) + "), got " + shape);
}

// An output shaped like the input: (k,) for one point, (N, k) for N.
py::array_t<double> Output(const Points& in, py::ssize_t n, int k) {
  if (in.ndim() == 1) return py::array_t<double>({static_cast<py::ssize_t>(k)});
  return py::array_t<double>({n, static_cast<py::ssize_t>(k)});
}

py::object Project(const CameraModel& c, const Points& points, bool gradients) {
  const py::ssize_t n = Rows(points, 3, "points");
  py::array_t<double> px = Output(points, n, 2);
  const int ni = static_cast<int>(c.intrinsics().size());
  py::array_t<double> dp({n, py::ssize_t{2}, py::ssize_t{3}});
  py::array_t<double> di({n, py::ssize_t{2}, static_cast<py::ssize_t>(ni)});
  const double* in = points.data();
  double* out = px.mutable_data();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  {
    py::gil_scoped_release release;
    Eigen::Matrix<double, 2, 3> j_p;
    Eigen::Matrix<double, 2, Eigen::Dynamic> j_i;
    for (py::ssize_t i = 0; i < n; ++i) {
      Eigen::Vector2d q;
      const bool ok = gradients ? c.Project(Eigen::Vector3d(in + 3 * i), &q, &j_p, &j_i)
                                : c.Project(Eigen::Vector3d(in + 3 * i), &q);
      out[2 * i] = ok ? q.x() : nan;
      out[2 * i + 1] = ok ? q.y() : nan;
      if (!gradients) continue;
      double* g = dp.mutable_data(i);
      double* h = di.mutable_data(i);
      for (int r = 0; r < 2; ++r) {
        for (int k = 0; k < 3; ++k) g[3 * r + k] = ok ? j_p(r, k) : nan;
        for (int k = 0; k < ni; ++k) h[ni * r + k] = ok ? j_i(r, k) : nan;
      }
    }
  }
  if (!gradients) return px;
  if (points.ndim() == 1) {
    return py::make_tuple(px, dp.attr("reshape")(2, 3), di.attr("reshape")(2, ni));
  }
  return py::make_tuple(px, dp, di);
}

py::array_t<double> Unproject(const CameraModel& c, const Points& pixels) {
  const py::ssize_t n = Rows(pixels, 2, "pixels");
  py::array_t<double> dirs = Output(pixels, n, 3);
  const double* in = pixels.data();
  double* out = dirs.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < n; ++i) {
      Eigen::Vector3d d;
      if (!c.Unproject(Eigen::Vector2d(in + 2 * i), &d))
        d.setConstant(std::numeric_limits<double>::quiet_NaN());
      for (int k = 0; k < 3; ++k) out[3 * i + k] = d(k);
    }
  }
  return dirs;
}

}  // namespace

void BindCamera(py::module_& m) {
  py::class_<CameraModel>(
      m, "Camera",
      "A calibrated camera: an mrcal lens model, its intrinsics (fx, fy, cx, cy, then the "
      "distortion; pixels) and the image size. Projection and unprojection are mrcal's (its C "
      "library). Camera frame: x right, y down, z forward (metres); pixel (0, 0) is the centre of "
      "the top-left pixel.\n\n"
      "Camera(path): reads an mrcal .cameramodel (and its covariance sidecar "
      "PATH.covariance.json when there is one).\n"
      "Camera(lensmodel, intrinsics, imagersize): from mrcal's lens model name, e.g. "
      "'LENSMODEL_OPENCV8', its intrinsics and (width, height).\n"
      "Camera.from_mrcal(mrcal.cameramodel), Camera.from_opencv(K, dist, imagersize), "
      "Camera.pinhole(f, width, height): see their own help.")
      .def(py::init([](const std::filesystem::path& path) { return ReadCamera(path, true); }),
           py::arg("path"))
      .def(py::init([](const std::string& lensmodel, const std::vector<double>& intrinsics,
                       std::pair<int, int> imagersize) {
             CameraModel c;
             RaiseIfError(CameraModel::Create(lensmodel, intrinsics, imagersize.first,
                                              imagersize.second, &c));
             return c;
           }),
           py::arg("lensmodel"), py::arg("intrinsics"), py::arg("imagersize"))
      .def_static("read", &ReadCamera, py::arg("path"), py::arg("sidecar") = true,
                  "Reads an mrcal .cameramodel; with `sidecar`, also PATH.covariance.json (the "
                  "intrinsics' uncertainty) when it exists. OSError for a missing file, "
                  "ValueError (naming the file and field) for a bad one.")
      .def_static(
          "_from_opencv",
          [](const Eigen::Matrix3d& K, const std::vector<double>& dist, std::pair<int, int> size) {
            OpenCvCamera c;
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) c.K[i][j] = K(i, j);
            c.dist = dist;
            c.width = size.first, c.height = size.second;
            CameraModel camera;
            RaiseIfError(CameraFromOpenCv(c, &camera));
            return camera;
          },
          py::arg("K"), py::arg("dist"), py::arg("imagersize"),
          "CameraFromOpenCv (camera/opencv_camera.h), which `svms camera import` uses too: see "
          "Camera.from_opencv.")
      .def_static(
          "pinhole",
          [](double f, int width, int height) {
            if (!(f > 0 && std::isfinite(f)) || width < 1 || height < 1)
              throw py::value_error(
                  "pinhole: expected f > 0 (pixels) and a size of at least 1 x 1, got f " +
                  std::to_string(f) + ", " + std::to_string(width) + " x " +
                  std::to_string(height));
            return CameraModel::Pinhole(f, width, height);
          },
          py::arg("f"), py::arg("width"), py::arg("height"),
          "A pinhole camera, fx = fy = f (pixels), principal point at ((width - 1) / 2, "
          "(height - 1) / 2).")
      .def_property_readonly("lensmodel", &CameraModel::lensmodel, "mrcal's canonical name")
      .def_property_readonly(
          "intrinsics",
          [](const CameraModel& c) {
            return py::array_t<double>(static_cast<py::ssize_t>(c.intrinsics().size()),
                                       c.intrinsics().data());
          },
          "fx, fy, cx, cy (pixels), then the lens model's distortion parameters (a copy)")
      .def_property_readonly("width", &CameraModel::width, "pixels")
      .def_property_readonly("height", &CameraModel::height, "pixels")
      .def_property_readonly(
          "imagersize", [](const CameraModel& c) { return py::make_tuple(c.width(), c.height()); },
          "(width, height), pixels")
      .def_property("cam_from_ref", &CameraModel::cam_from_ref, &CameraModel::set_cam_from_ref,
                    "the .cameramodel's extrinsics (mrcal's rt_cam_ref as a Pose); not used by "
                    "project")
      .def_property(
          "intrinsics_covariance_factor", &CameraModel::intrinsics_covariance_factor,
          [](CameraModel& c, const Eigen::MatrixXd& f) {
            RaiseIfError(c.set_intrinsics_covariance_factor(f));
          },
          "L with Cov(intrinsics) = L L^T (N x N), or 0 x 0 when the uncertainty is unknown")
      .def("project", &Project, py::arg("points"), py::arg("gradients") = false,
           "Pixels of points in the camera frame: (3,) -> (2,), (N, 3) -> (N, 2); NaN where a "
           "point cannot be projected (behind a camera that cannot see there, non-finite). With "
           "gradients=True returns (pixels, dpixels_dpoints (N, 2, 3), dpixels_dintrinsics (N, 2, "
           "M)), mrcal's analytic gradients (mrcal.project(..., get_gradients=True)).")
      .def("unproject", &Unproject, py::arg("pixels"),
           "Unit directions in the camera frame of pixels: (2,) -> (3,), (N, 2) -> (N, 3); NaN "
           "where a pixel cannot be unprojected.")
      .def(
          "write",
          [](const CameraModel& c, const std::filesystem::path& path) {
            // With the covariance sidecar when the camera has one, and without an earlier
            // sidecar left beside it (it would belong to another calibration).
            RaiseIfError(WriteCameraWithSidecar(path.string(), c, 0, 0));
          },
          py::arg("path"),
          "Writes an mrcal .cameramodel (atomically; exact round trip) and, when the camera "
          "carries its intrinsics' covariance, its PATH.covariance.json sidecar; an earlier "
          "sidecar of another calibration is removed")
      .def(
          "to_text",
          [](const CameraModel& c) {
            std::string text;
            RaiseIfError(c.ToText("camera", &text));
            return text;
          },
          "the .cameramodel text (what mrcal.cameramodel(io.StringIO(text)) reads)")
      .def("unusable_reason", &CameraModel::UnusableReason,
           "'' when poses can be measured with this camera, else why not")
      .def("__repr__", [](const CameraModel& c) { return "<svms.Camera " + c.Summary() + ">"; });
}

}  // namespace svms::python
