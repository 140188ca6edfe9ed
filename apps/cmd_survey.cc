// svms survey: where the markers sit on one object, from many images of it (bundle/).
#include <atomic>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "cli_io.h"
#include "commands.h"
#include "gnuplot.h"
#include "image_inputs.h"
#include "progress.h"
#include "svms/base/format.h"
#include "svms/bundle/survey.h"
#include "svms/bundle/survey_report.h"
#include "svms/camera/camera_covariance.h"
#include "svms/detect/detector.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/model_io.h"

namespace svms::cli {
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

}  // namespace

int RunSurveyCommand(const SurveyCliOptions& o) {
  auto bad_input = [](const std::string& m) {
    std::cerr << "svms survey: " << m << "\n";
    return kExitBadInput;
  };
  CameraModel camera;
  if (Status s = ReadCameraWithSidecar(o.camera, &camera); !s) return bad_input(s.message());
  Photometry photometry;
  if (Status s = Photometry::Create(o.photometry, o.camera, &photometry); !s)
    return bad_input(s.message());
  ModelFile models;
  if (Status s = ReadModelFile(o.markers, &models); !s) return bad_input(s.message());
  SurveyOptions options;
  if (o.corner_sigma) {
    if (!(std::isfinite(*o.corner_sigma) && *o.corner_sigma > 0))
      return bad_input("--corner-sigma " +
                       [&] {
                         std::ostringstream ss;
                         ss << *o.corner_sigma;
                         return ss.str();
                       }() +
                       ": expected a positive number of pixels (leave it out for each corner's "
                       "own sigma)");
    options.corner_sigma_px = *o.corner_sigma;
    options.corner_sigma_from_fit = false;
  }
  options.num_threads = o.threads;
  SurveyConfig config;
  if (o.reference) {
    if (*o.reference < 0)
      return bad_input("--reference " + std::to_string(*o.reference) +
                       ": expected the ID of a marker in " + o.markers + " (0 to 32767)");
    bool known = false;
    for (const MarkerModel& m : models.markers)
      known = known || m.id == *o.reference || (m.inner && m.inner->id == *o.reference);
    if (!known)
      return bad_input("--reference " + std::to_string(*o.reference) +
                       ": no marker with that ID in " + o.markers +
                       "; expected the ID of one of its markers");
    config.reference_id = *o.reference;
  }
  config.refine_intrinsics = o.refine_intrinsics;
  config.drop_disconnected = o.drop_disconnected;
  for (const std::string& t : o.scale_bars) {
    ScaleBar bar;
    if (Status s = ParseScaleBar(t, &bar); !s) return bad_input(s.message());
    config.scale_bars.push_back(bar);
  }
  for (const std::string& t : o.control_points) {
    ControlPoint cp;
    if (Status s = ParseControlPoint(t, &cp); !s) return bad_input(s.message());
    config.control_points.push_back(cp);
  }
  if (!config.control_points.empty()) {
    if (o.reference)
      return bad_input("--reference and --control-point both fix the object frame; give one");
    config.gauge = SurveyConfig::Gauge::kControlPoints;
  } else if (!o.reference) {
    return bad_input("the object frame: expected --reference ID or three --control-point");
  }
  if (Status s = options.Check(); !s) return bad_input(s.message());
  if (Status s = config.Check(); !s) return bad_input(s.message());

  // Outputs: none may replace an input; the report directory must be writable (checked now,
  // not after the solve).
  const std::vector<std::string> files = ExpandImageInputs(o.inputs);
  if (files.empty()) return bad_input("no images given");
  std::vector<std::string> inputs = files;
  inputs.push_back(o.camera);
  inputs.push_back(CovarianceSidecarPath(o.camera));
  inputs.push_back(o.markers);
  if (Status s = CheckNotAnInput("--out", o.out, inputs); !s) return bad_input(s.message());
  if (!o.report.empty())
    if (Status s = PrepareOutputDirectory("--report", o.report); !s) return bad_input(s.message());

  // Detect.
  const Detector detector(DetectorOptions{}, camera, models.markers);
  std::vector<SurveyImage> images(files.size());
  std::vector<std::string> errors(files.size());
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress progress("svms survey: detecting", files.size(), "", !o.quiet);
  auto worker = [&] {
    for (size_t i; (i = next++) < files.size();) {
      images[i].name = fs::path(files[i]).stem().string();
      cv::Mat img;
      try {
        if (Status s = photometry.Load(files[i], kDefaultMaxImagePixels, &img, nullptr); !s)
          errors[i] = s.message();
        else if (img.cols != camera.width() || img.rows != camera.height())
          errors[i] = files[i] + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                      " pixels, but the camera model is " + std::to_string(camera.width()) + "x" +
                      std::to_string(camera.height());
        else
          images[i].detections = detector.Detect(img);
      } catch (...) {
        errors[i] = ItemFailure(files[i], std::current_exception());
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
  int unreadable = 0;
  for (const std::string& e : errors)
    if (!e.empty()) {
      std::cerr << "svms survey: " << e << " (skipped)\n";
      ++unreadable;
    }

  // Survey.
  if (!o.quiet) std::cerr << "svms survey: solving\n";
  SurveyResult result;
  const Status s = RunSurvey(images, models.markers, camera, options, config, &result);
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
  result.layout.name =
      "survey of " + std::to_string(result.summary.images_used) +
      " images; covariances scaled by the a-posteriori variance factor " +
      std::to_string(result.summary.variance_factor) +
      (result.summary.calibration_in_covariance ? ", plus the camera calibration's uncertainty"
                                                : "") +
      (result.summary.corner_repeat_in_covariance
           ? ", plus the repeated corner error of the markers seen with grey levels"
           : "");
  // The layout last: a report that could not be written (a full disk) leaves the earlier
  // layout as it was.
  if (report_failed) {
    std::cerr << "svms survey: the layout was not written\n";
    return kExitFailed;
  }
  if (Status w = WriteTextFile(o.out, LayoutToJson(result.layout)); !w) {
    std::cerr << "svms survey: " << w.message() << "\n";
    return kExitFailed;
  }
  if (!o.quiet) std::cerr << "svms survey: wrote " << o.out << "\n";
  if (unreadable)
    std::cerr << "svms survey: " << unreadable << " of " << files.size()
              << " images could not be used\n";
  return unreadable || report_failed ? kExitFailed : kExitOk;
}

void AddSurveyCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<SurveyCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "survey", "Survey where several markers sit on one object, from many images of it");
  cmd->add_option("IMAGES", o->inputs, "Image files, directories or globs")->required();
  cmd->add_option("--camera", o->camera, "mrcal .cameramodel of the images")->required();
  cmd->add_option("--markers", o->markers, "Marker models (svms.markers or svms.layout)")
      ->required();
  cmd->add_option("--reference", o->reference, "ID of the marker whose frame is the object frame");
  cmd->add_option("--control-point", o->control_points,
                  "NAME=X,Y,Z[,SIGMA]: a point with known object coordinates (three or more "
                  "instead of --reference); NAME is ID, ID.tl/.tr/.br/.bl or ID.tip");
  cmd->add_option("--scale-bar", o->scale_bars,
                  "A:B:DISTANCE[:SIGMA]: a measured distance between two named points (metres; "
                  "sigma 1e-4 by default)");
  cmd->add_flag("--refine-intrinsics", o->refine_intrinsics, "Refine the camera's intrinsics too");
  cmd->add_flag("--drop-disconnected", o->drop_disconnected,
                "Survey only the reference's group when the view graph is disconnected");
  cmd->add_option("--corner-sigma", o->corner_sigma,
                  "Standard deviation of every corner (px); by default each corner's own, from "
                  "the detector's line fits (x " +
                      Fixed(kCornerFitScale, 2) + ")");
  cmd->add_option("--out", o->out, "The layout JSON to write (svms.layout, with covariances)")
      ->required();
  cmd->add_option("--report", o->report, "Write report.md, tables and pictures to this directory");
  cmd->add_option("--threads", o->threads, "Threads for detection and the solver")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  AddPhotometryOptions(cmd, &o->photometry);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->footer(
      "Each marker's pose in the object frame with a 6x6 covariance ([rotation, translation],\n"
      "object axes, scaled by the a-posteriori variance factor), each post's height with its\n"
      "sigma. A dual marker is written as two entries (outer and inner) with their own poses.\n"
      "Exit codes: 0 ok; 1 the survey failed (disconnected views, rank deficiency, ...);\n"
      "2 bad input.\n"
      "Examples:\n"
      "  svms survey out/mockup --camera out/mockup/true.cameramodel --markers "
      "out/mockup/markers.json --reference 10 --out layout.json --report out/survey\n"
      "  svms survey imgs/ --camera cam.cameramodel --markers m.json --reference 3 "
      "--scale-bar 3.tl:7.tl:1.2031 --out layout.json");
  cmd->callback([o, exit_code] { *exit_code = RunSurveyCommand(*o); });
}

}  // namespace svms::cli
