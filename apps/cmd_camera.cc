// svms camera: OpenCV camera files in and out of mrcal .cameramodel files, and what a camera
// model holds (svms/camera/opencv_camera.h, svms/camera/camera_info.h).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <tuple>

#include "commands.h"
#include "svms/base/format.h"
#include "svms/camera/camera_covariance.h"
#include "svms/camera/camera_info.h"
#include "svms/camera/opencv_camera.h"
#include "svms/pipelines/mrcal_uncertainty.h"
#include "svms/pipelines/output_checks.h"

namespace svms::cli {
namespace {

struct CameraCliOptions {
  std::string input, out, image_size, format = "opencv";
  std::vector<std::string> show;
  MrcalUncertaintyOptions mrcal;
};

std::string Fixed1(double v) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

// "WxH" -> width, height (positive). False on anything else.
bool ParseImageSize(const std::string& s, int* w, int* h) {
  char x = 0, extra = 0;
  return std::sscanf(s.c_str(), "%d%c%d%c", w, &x, h, &extra) == 3 && (x == 'x' || x == 'X') &&
         *w > 0 && *h > 0;
}

int RunImport(const CameraCliOptions& o) {
  int w = 0, h = 0;
  if (!o.image_size.empty() && !ParseImageSize(o.image_size, &w, &h)) {
    std::cerr << "svms camera import: --image-size " << o.image_size
              << ": expected WIDTHxHEIGHT in pixels, e.g. 1280x960\n";
    return kExitBadInput;
  }
  if (Status s = CheckNotAnInput("--out", o.out, {o.input}); !s) {
    std::cerr << "svms camera import: " << s.message() << "\n";
    return kExitBadInput;
  }
  CameraModel cam;
  if (Status s = ImportOpenCvCamera(o.input, w, h, &cam); !s) {
    std::cerr << s.message() << "\n";
    return kExitBadInput;
  }
  // Written with the sidecar rule: an earlier CAM.cameramodel.covariance.json belonged to
  // another camera and is removed with the model it described.
  if (Status s = WriteCameraWithSidecar(o.out, cam, 0, 0); !s) {
    std::cerr << s.message() << "\n";
    return kExitFailed;
  }
  std::cout << o.out << ": " << cam.Summary() << " (from " << o.input << ")\n";
  return kExitOk;
}

int RunExport(const CameraCliOptions& o) {
  if (o.format != "opencv") {
    std::cerr << "svms camera export: --format " << o.format << ": expected opencv\n";
    return kExitBadInput;
  }
  if (Status s = CheckNotAnInput("--out", o.out, {o.input, CovarianceSidecarPath(o.input)}); !s) {
    std::cerr << "svms camera export: " << s.message() << "\n";
    return kExitBadInput;
  }
  CameraModel cam;
  if (Status s = CameraModel::Read(o.input, &cam); !s) {
    std::cerr << s.message() << "\n";
    return kExitBadInput;
  }
  // A lens model OpenCV lacks is bad input; past that check, an error is a failed write.
  OpenCvCamera as_opencv;
  if (Status s = OpenCvFromCamera(cam, &as_opencv); !s) {
    std::cerr << o.input << ": " << s.message() << "\n";
    return kExitBadInput;
  }
  if (Status s = WriteOpenCvCameraFile(o.out, cam); !s) {
    std::cerr << s.message() << "\n";
    return kExitFailed;
  }
  std::cout << o.out << ": OpenCV camera (" << cam.Summary() << ")\n";
  if (!cam.cam_from_ref().rvec.isZero(0) || !cam.cam_from_ref().tvec.isZero(0)) {
    std::cerr << "svms camera export: note: " << o.input
              << " has extrinsics (rt_cam_ref); an OpenCV camera file has none, they are not "
                 "written\n";
  }
  return kExitOk;
}

void PrintInfo(const std::string& path, const CameraInfo& info) {
  const CameraModel& c = info.camera;
  const std::vector<double>& in = c.intrinsics();
  std::cout << path << ": " << c.lensmodel() << ", " << c.width() << "x" << c.height()
            << " pixels\n";
  if (in.size() >= 4 && info.distortion_count >= 0) {
    std::cout << "  fx " << RoundTrip(in[0]) << "  fy " << RoundTrip(in[1]) << "  cx "
              << RoundTrip(in[2]) << "  cy " << RoundTrip(in[3]) << " (pixels)\n";
  }
  std::cout << "  field of view: " << Fixed1(info.fov_x_deg) << " x " << Fixed1(info.fov_y_deg)
            << " degrees (edge to edge, through the image centre)\n";
  std::cout << "  distortion: ";
  if (c.lensmodel() == "LENSMODEL_PINHOLE") {
    std::cout << "none (pinhole)\n";
  } else {
    if (!info.distortion.empty()) {
      for (const auto& [name, value] : info.distortion) {
        std::cout << name << " " << RoundTrip(value)
                  << (&value == &info.distortion.back().second ? "; " : ", ");
      }
    } else {
      std::cout << info.distortion_count << " parameters; ";
    }
    std::cout << "moves pixels by up to " << Fixed1(info.max_distortion_px)
              << " px from the pinhole image\n";
  }
  std::cout << "  uncertainty: ";
  if (info.sidecar_path.empty()) {
    std::cout << "none (no " << CovarianceSidecarPath(path)
              << "; poses leave the calibration's error out)\n";
  } else if (info.sidecar_error.empty()) {
    std::cout << info.sidecar_path << " (intrinsics covariance, used by svms pose)\n";
  } else {
    std::cout << info.sidecar_path << " is not usable: " << info.sidecar_error << "\n";
  }
  std::cout << "  mrcal optimization_inputs: "
            << (!info.has_optimization_inputs ? "no\n"
                : info.sidecar_path.empty()
                    ? "yes (`svms camera import-uncertainty " + path + "` writes the sidecar)\n"
                    : std::string("yes (mrcal's tools can compute its projection uncertainty)\n"));
  if (std::string why = c.UnusableReason(); !why.empty()) {
    std::cout << "  cannot measure poses: " << why << "\n";
  }
}

int RunShow(const CameraCliOptions& o) {
  int bad = 0;
  for (const std::string& path : o.show) {
    CameraInfo info;
    if (Status s = ReadCameraInfo(path, &info); !s) {
      std::cerr << s.message() << "\n";
      ++bad;
      continue;
    }
    PrintInfo(path, info);
  }
  return bad ? kExitBadInput : kExitOk;
}

// The worst-direction standard deviation (pixels) of a 2x2 covariance, as mrcal's
// worst_direction_stdev.
double WorstDirectionSigma(const Eigen::Matrix2d& c) {
  const double a = c(0, 0), b = c(1, 0), d = c(1, 1);
  return std::sqrt((a + d) / 2 + std::sqrt((a - d) * (a - d) / 4 + b * b));
}

int RunImportUncertainty(const CameraCliOptions& o) {
  MrcalUncertaintyResult r;
  if (Status s = ImportMrcalUncertainty(o.mrcal, &r); !s) {
    std::cerr << "svms camera import-uncertainty: " << s.message() << "\n";
    // r.sidecar is set only when the write itself failed.
    return r.sidecar.empty() ? kExitBadInput : kExitFailed;
  }
  std::cout << r.sidecar << ": intrinsics covariance from mrcal's optimization_inputs (" << r.views
            << " board views, corner noise " << Significant(r.noise_sigma_px, 3) << " px)\n";
  // mrcal's projection uncertainty at infinity, from the sidecar: at the centre and the corners.
  const CameraModel& c = r.camera;
  const double w = c.width() - 1, h = c.height() - 1;
  std::cout << "  projection uncertainty at infinity (mrcal's, worst direction):";
  for (const auto& [name, u, v] : {std::tuple<const char*, double, double>{"centre", w / 2, h / 2},
                                   {"top-left", 0, 0},
                                   {"top-right", w, 0},
                                   {"bottom-left", 0, h},
                                   {"bottom-right", w, h}}) {
    Eigen::Vector3d d;
    Eigen::Matrix2d cov;
    std::cout << " " << name << " ";
    if (c.Unproject(Eigen::Vector2d(u, v), &d) &&
        MeanFramesProjectionCovariance(c, r.mean_frames_factor, d, true, &cov))
      std::cout << Significant(WorstDirectionSigma(cov), 3) << " px";
    else
      std::cout << "n/a";
  }
  std::cout << "\n";
  return kExitOk;
}

}  // namespace

void AddCameraCommands(CLI::App& app, int* exit_code) {
  CLI::App* camera = app.add_subcommand(
      "camera", "Camera model files: OpenCV in and out, show, mrcal's uncertainty");
  camera->require_subcommand(1);
  auto o = std::make_shared<CameraCliOptions>();

  auto* import_cmd =
      camera->add_subcommand("import", "An OpenCV camera file as an mrcal .cameramodel");
  import_cmd
      ->add_option("FILE", o->input, "OpenCV camera (cv::FileStorage YAML, XML or JSON; ROS YAML)")
      ->required();
  import_cmd->add_option("--out", o->out, "the mrcal camera model to write (CAM.cameramodel)")
      ->required();
  import_cmd->add_option("--image-size", o->image_size,
                         "WIDTHxHEIGHT in pixels, for a file without image_width/image_height");
  import_cmd->footer(
      "Reads camera_matrix (cameraMatrix, K), distortion_coefficients (distCoeffs, dist_coeffs,\n"
      "D) and image_width/image_height (imageSize): k1 k2 p1 p2 [k3 [k4 k5 k6 [s1..s4]]] become\n"
      "LENSMODEL_OPENCV4/5/8/12, no distortion LENSMODEL_PINHOLE (docs/conventions.md).\n"
      "Skew, a tilted sensor and cv::fisheye have no mrcal 2.2 model and are refused (exit 2).\n"
      "Examples:\n  svms camera import opencv_cam.yml --out cam.cameramodel\n"
      "  svms camera import ost.yaml --image-size 1280x960 --out cam.cameramodel");
  import_cmd->callback([o, exit_code] { *exit_code = RunImport(*o); });

  auto* exp = camera->add_subcommand("export", "An mrcal camera model as an OpenCV camera file");
  exp->add_option("CAM", o->input, "mrcal camera model (LENSMODEL_PINHOLE or _OPENCV4/5/8/12)")
      ->required();
  exp->add_option("--format", o->format, "output format: opencv")->required();
  exp->add_option("--out", o->out, "the file to write: .yml/.yaml (YAML), .xml, .json")->required();
  exp->footer(
      "Writes image_width, image_height, camera_matrix and distortion_coefficients with\n"
      "cv::FileStorage, every number exact (17 digits). Extrinsics and the covariance sidecar\n"
      "have no place in an OpenCV camera file and are not written.\n"
      "Example:\n  svms camera export cam.cameramodel --format opencv --out cam.yml");
  exp->callback([o, exit_code] { *exit_code = RunExport(*o); });

  auto* show = camera->add_subcommand("show", "What a camera model holds");
  show->add_option("CAM", o->show, "mrcal camera models")->required();
  show->footer(
      "Prints the lens model, image size, intrinsics, field of view, the distortion and how far\n"
      "it moves pixels, whether the intrinsics' covariance sidecar (CAM.covariance.json) is\n"
      "there and matches, and whether the file has mrcal's optimization_inputs.\n"
      "Example:\n  svms camera show cam.cameramodel");
  show->callback([o, exit_code] { *exit_code = RunShow(*o); });

  auto* unc = camera->add_subcommand(
      "import-uncertainty", "The covariance sidecar of a camera calibrated by mrcal's tools");
  unc->add_option("CAM", o->mrcal.camera, "mrcal camera model with optimization_inputs")
      ->required();
  unc->add_option("--observed-pixel-uncertainty", o->mrcal.observed_pixel_uncertainty,
                  "corner noise in pixels (default: from the residuals, as mrcal does)")
      ->check(CLI::PositiveNumber);
  unc->add_option("--python", o->mrcal.python,
                  "the Python with mrcal 2.2 (default /usr/bin/python3)");
  unc->footer(
      "Runs mrcal's Python once on the model's optimization_inputs and writes CAM.covariance.json\n"
      "(the intrinsics' covariance, computed as mrcal.projection_uncertainty computes it), which\n"
      "svms detect, pose, survey and the C API then use. See docs/conventions.md.\n"
      "Example:\n  svms camera import-uncertainty camera-0.cameramodel");
  unc->callback([o, exit_code] { *exit_code = RunImportUncertainty(*o); });
}

}  // namespace svms::cli
