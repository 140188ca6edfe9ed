#include "svms/pipelines/survey_run.h"

#include <atomic>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <sstream>

#include "svms/base/file_io.h"
#include "svms/base/format.h"
#include "svms/bundle/survey.h"
#include "svms/bundle/survey_report.h"
#include "svms/camera/camera_covariance.h"
#include "svms/detect/detector.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/mrcal_uncertainty.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string part; std::getline(ss, part, sep);) out.push_back(part);
  return out;
}

bool ParseNumber(const std::string& s, double* v) {
  try {
    size_t used = 0;
    *v = std::stod(s, &used);
    return used == s.size() && std::isfinite(*v);
  } catch (...) {
    return false;
  }
}

// A:B:DIST[:SIGMA]
Status ParseScaleBar(const std::string& text, ScaleBar* bar) {
  const std::vector<std::string> p = Split(text, ':');
  const Status bad = Status::Error(
      "--scale-bar " + text + ": expected A:B:DISTANCE[:SIGMA] in metres, e.g. 12.tl:17.tl:1.2345");
  if (p.size() < 3 || p.size() > 4) return bad;
  if (Status s = ParseNamedPoint(p[0], &bar->a); !s)
    return Status::Error("--scale-bar " + text + ": " + s.message());
  if (Status s = ParseNamedPoint(p[1], &bar->b); !s)
    return Status::Error("--scale-bar " + text + ": " + s.message());
  if (!ParseNumber(p[2], &bar->distance)) return bad;
  if (p.size() == 4 && !ParseNumber(p[3], &bar->sigma)) return bad;
  return Status::Ok();
}

// NAME=X,Y,Z[,SIGMA]
Status ParseControlPoint(const std::string& text, ControlPoint* cp) {
  const Status bad = Status::Error("--control-point " + text +
                                   ": expected NAME=X,Y,Z[,SIGMA] in metres, e.g. 10.tl=0,0.2,1");
  const size_t eq = text.find('=');
  if (eq == std::string::npos) return bad;
  if (Status s = ParseNamedPoint(text.substr(0, eq), &cp->point); !s)
    return Status::Error("--control-point " + text + ": " + s.message());
  const std::vector<std::string> v = Split(text.substr(eq + 1), ',');
  if (v.size() < 3 || v.size() > 4) return bad;
  for (int i = 0; i < 3; ++i)
    if (!ParseNumber(v[i], &cp->point_in_object[i])) return bad;
  if (v.size() == 4 && !ParseNumber(v[3], &cp->sigma)) return bad;
  return Status::Ok();
}

// The solver's options and configuration from the run's options, checked against the marker
// models. kExitOk to go on.
int MakeSurveySettings(const SurveyRunOptions& o, const ModelFile& models, SurveyOptions* options,
                       SurveyConfig* config) {
  if (o.corner_sigma) {
    if (!(std::isfinite(*o.corner_sigma) && *o.corner_sigma > 0))
      return BadInput("svms survey",
                      "--corner-sigma " + Significant(*o.corner_sigma, 6) +
                          ": expected a positive number of pixels (leave it out for each corner's "
                          "own sigma)");
    options->corner_sigma_px = *o.corner_sigma;
    options->corner_sigma_from_fit = false;
  }
  options->num_threads = o.threads;
  if (o.reference) {
    if (*o.reference < 0)
      return BadInput("svms survey", "--reference " + std::to_string(*o.reference) +
                                         ": expected the ID of a marker in " + o.markers +
                                         " (0 to 32767)");
    bool known = false;
    for (const MarkerModel& m : models.markers)
      known = known || m.id == *o.reference || (m.inner && m.inner->id == *o.reference);
    if (!known)
      return BadInput("svms survey", "--reference " + std::to_string(*o.reference) +
                                         ": no marker with that ID in " + o.markers +
                                         "; expected the ID of one of its markers");
    config->reference_id = *o.reference;
  }
  config->refine_intrinsics = o.refine_intrinsics;
  config->drop_disconnected = o.drop_disconnected;
  for (const std::string& t : o.scale_bars) {
    ScaleBar bar;
    if (Status s = ParseScaleBar(t, &bar); !s) return BadInput("svms survey", s.message());
    config->scale_bars.push_back(bar);
  }
  for (const std::string& t : o.control_points) {
    ControlPoint cp;
    if (Status s = ParseControlPoint(t, &cp); !s) return BadInput("svms survey", s.message());
    config->control_points.push_back(cp);
  }
  if (!config->control_points.empty()) {
    if (o.reference)
      return BadInput("svms survey",
                      "--reference and --control-point both fix the object frame; give one");
    config->gauge = SurveyConfig::Gauge::kControlPoints;
  } else if (!o.reference) {
    return BadInput("svms survey",
                    "the object frame: expected --reference ID or three --control-point");
  }
  if (Status s = options->Check(); !s) return BadInput("svms survey", s.message());
  if (Status s = config->Check(); !s) return BadInput("svms survey", s.message());
  return kExitOk;
}

// Outputs: none may replace an input; the report directory must be writable (checked now,
// not after the solve). kExitOk to go on.
int CheckOutputs(const SurveyRunOptions& o, const std::vector<std::string>& files) {
  if (files.empty()) return BadInput("svms survey", "no images given");
  std::vector<std::string> inputs = files;
  inputs.push_back(o.camera);
  inputs.push_back(CovarianceSidecarPath(o.camera));
  inputs.push_back(o.markers);
  if (Status s = CheckNotAnInput("--out", o.out, inputs); !s)
    return BadInput("svms survey", s.message());
  if (!o.out_camera.empty()) {
    for (const std::string& path : {o.out_camera, CovarianceSidecarPath(o.out_camera)})
      if (Status s = CheckNotAnInput("--out-camera", path, inputs); !s)
        return BadInput("svms survey", s.message());
    // The layout and the camera are written as one group: three distinct files.
    std::error_code out_ec;
    const fs::path out = fs::weakly_canonical(o.out, out_ec);
    for (const std::string& path : {o.out_camera, CovarianceSidecarPath(o.out_camera)}) {
      std::error_code ec;
      const fs::path p = fs::weakly_canonical(path, ec);
      if ((!ec && !out_ec && p == out) || path == o.out)
        return BadInput("svms survey", "--out-camera " + o.out_camera + ": writes " + path +
                                           ", which is --out; expected another file name");
    }
  }
  if (!o.report.empty())
    if (Status s = PrepareOutputDirectory("--report", o.report); !s)
      return BadInput("svms survey", s.message());
  return kExitOk;
}

// Detects the markers in every image on o.threads threads. An image that cannot be used (or is
// not of the camera's size) gets an error in *errors and no detections.
std::vector<SurveyImage> DetectAll(const SurveyRunOptions& o, const std::vector<std::string>& files,
                                   const CameraModel& camera, const ModelFile& models,
                                   const Photometry& photometry, std::vector<std::string>* errors) {
  DetectorOptions options;
  options.refine.max_row_window_px = photometry.CornerRowWindowPx();
  const Detector detector(options, camera, models.markers);
  std::vector<SurveyImage> images(files.size());
  errors->assign(files.size(), "");
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress progress("svms survey: detecting", files.size(), "", !o.quiet);
  auto worker = [&] {
    for (size_t i; (i = next++) < files.size();) {
      images[i].name = fs::path(files[i]).stem().string();
      std::string& error = (*errors)[i];
      cv::Mat img;
      NoiseModel noise;  // a raw frame's, from its stored values (noise_model.h)
      try {
        if (Status s =
                photometry.Load(files[i], kDefaultMaxImagePixels, &img, nullptr, nullptr, &noise);
            !s)
          error = s.message();
        else if (img.cols != camera.width() || img.rows != camera.height())
          error = files[i] + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                  " pixels, but the camera model is " + std::to_string(camera.width()) + "x" +
                  std::to_string(camera.height());
        else
          detector.Detect(img, nullptr, std::chrono::steady_clock::time_point::max(),
                          &images[i].detections, noise.valid() ? &noise : nullptr);
      } catch (...) {
        error = ItemFailure(files[i], std::current_exception());
      }
      std::lock_guard<std::mutex> lock(io);
      progress.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, std::min<int>(o.threads, static_cast<int>(files.size()))); ++t)
    pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  progress.Finish();
  return images;
}

// Solves, writes the report (when asked) and then the layout. The exit code of the run but
// for the images that could not be used.
int SolveAndWrite(const SurveyRunOptions& o, const std::vector<SurveyImage>& images,
                  const ModelFile& models, const CameraModel& camera, const SurveyOptions& options,
                  const SurveyConfig& config) {
  if (!o.quiet) std::cerr << "svms survey: solving\n";
  SurveyResult result;
  const Status s = RunSurvey(images, models.markers, camera, options, config, &result);
  result.summary.refined_camera = o.out_camera;
  if (!o.quiet || !s) std::cerr << result.summary.BriefReport();
  bool report_failed = false;
  if (!o.report.empty()) {
    if (Status w = WriteSurveyReport(result, o.report, Gnuplot); !w) {
      std::cerr << "svms survey: --report: " << w.message() << "\n";
      report_failed = true;
    }
  }
  if (!s) {
    std::cerr << "svms survey: " << s.message() << "\n";
    return kExitFailed;
  }
  result.layout.name = result.summary.LayoutName();
  // The layout last: a report that could not be written (a full disk) leaves the earlier
  // layout as it was.
  if (report_failed) {
    std::cerr << "svms survey: the layout was not written\n";
    return kExitFailed;
  }
  // The layout, and with --out-camera the refined camera and its sidecar, as one group: a
  // layout never replaces an earlier one without the camera it belongs to.
  AtomicFileSet files;
  if (!o.out_camera.empty()) {
    const double noise_sigma_px = result.summary.rms_px / std::sqrt(2.0);  // per coordinate
    if (Status w = AddCameraWithSidecar(o.out_camera, result.camera, noise_sigma_px,
                                        result.summary.images_used, &files);
        !w) {
      std::cerr << "svms survey: --out-camera: " << w.message() << "\n";
      return kExitFailed;
    }
  }
  files.Add(o.out, LayoutToJson(result.layout)).ok();  // an error is Commit's
  if (Status w = files.Commit(); !w) {
    std::cerr << "svms survey: " << w.message() << "\n";
    return kExitFailed;
  }
  if (!o.quiet) {
    std::cerr << "svms survey: wrote " << o.out << "\n";
    if (!o.out_camera.empty())
      std::cerr << "svms survey: wrote " << o.out_camera << " and "
                << CovarianceSidecarPath(o.out_camera)
                << " (the refined camera the layout belongs to)\n";
  }
  return kExitOk;
}

}  // namespace

int RunSurveyFromImages(const SurveyRunOptions& o) {
  if (!o.out_camera.empty() && !o.refine_intrinsics)
    return BadInput("svms survey",
                    "--out-camera " + o.out_camera +
                        ": only with --refine-intrinsics (without it the camera is the input one)");
  CameraModel camera;
  if (Status s = ReadCameraWithSidecar(o.camera, &camera); !s)
    return BadInput("svms survey", s.message());
  if (std::string hint = MissingUncertaintyHint(o.camera); !hint.empty() && !o.quiet)
    std::cerr << "svms survey: " << hint << "\n";
  Photometry photometry;
  if (Status s = Photometry::Create(o.photometry, o.camera, &photometry); !s)
    return BadInput("svms survey", s.message());
  ModelFile models;
  if (Status s = ReadModelFile(o.markers, &models); !s) return BadInput("svms survey", s.message());
  SurveyOptions options;
  SurveyConfig config;
  if (const int rc = MakeSurveySettings(o, models, &options, &config); rc != kExitOk) return rc;
  const std::vector<std::string> files = ExpandImageInputs(o.inputs);
  if (const int rc = CheckOutputs(o, files); rc != kExitOk) return rc;

  std::vector<std::string> errors;
  const std::vector<SurveyImage> images = DetectAll(o, files, camera, models, photometry, &errors);
  int unreadable = 0;
  for (const std::string& e : errors)
    if (!e.empty()) {
      std::cerr << "svms survey: " << e << " (skipped)\n";
      ++unreadable;
    }
  const int rc = SolveAndWrite(o, images, models, camera, options, config);
  if (rc != kExitOk) return rc;
  if (unreadable)
    std::cerr << "svms survey: " << unreadable << " of " << files.size()
              << " images could not be used\n";
  return unreadable ? kExitFailed : kExitOk;
}

}  // namespace svms
