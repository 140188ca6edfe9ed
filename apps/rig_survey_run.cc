#include "rig_survey_run.h"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "rig_pose_stream.h"
#include "svms/base/file_io.h"
#include "svms/base/format.h"
#include "svms/bundle/rig_survey.h"
#include "svms/fusion/rig_pose_estimator.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/output_checks.h"

namespace svms::cli {
namespace {

constexpr const char* kProgram = "svms survey rig";

// Square roots of the rotation and translation blocks' traces: mrad and mm.
std::string Sigmas(const std::optional<PoseCovariance>& c) {
  if (!c) return "- | -";
  return Fixed(std::sqrt(c->topLeftCorner<3, 3>().trace()) * 1e3, 3) + " | " +
         Fixed(std::sqrt(c->bottomRightCorner<3, 3>().trace()) * 1e3, 3);
}

// The report: the fit's figures and one row per camera (markdown).
std::string Report(const RigSurveyRunOptions& o, const CameraRig& in, const RigSurveyResult& r,
                   size_t frames_listed) {
  const RigSurveySummary& s = r.summary;
  std::ostringstream t;
  t << "# Rig survey" << (in.name.empty() ? "" : ": " + in.name) << "\n\n"
    << "Rig " << o.rig << ", layout " << o.layout << ", frames " << o.frames_list << " -> " << o.out
    << ".\n\n"
    << "- frames: " << frames_listed << " listed, " << s.frames_used << " used\n"
    << "- residuals " << s.residuals << ", parameters " << s.parameters << ", dof " << s.dof << "\n"
    << "- RMS of the normalised residuals " << Fixed(s.rms_normalised, 3) << ", chi2/dof "
    << Fixed(s.variance_factor, 3) << " (noise's share " << Fixed(s.noise_variance_factor, 3)
    << (s.covariance_scaled ? ", the measurement part of the covariance scaled by it" : "") << ")\n"
    << "- in the covariance: layout " << (s.layout_in_covariance ? "yes" : "no") << ", calibration "
    << (s.calibration_in_covariance ? "yes" : "no") << ", reference camera's "
    << (s.reference_in_covariance ? "yes" : "no") << "\n"
    << "- Ceres: " << s.iterations << " iterations, " << Fixed(s.seconds, 2) << " s\n\n"
    << "| camera | frames | markers | points | rejected | RMS px | RMS sigma | rotation sigma "
       "mrad | translation sigma mm | moved from input mrad | mm |\n"
    << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t c = 0; c < r.cameras.size(); ++c) {
    const RigSurveyCamera& k = r.cameras[c];
    const Pose& before = in.cameras[c].rig_from_cam;
    t << "| " << in.cameras[c].name << (k.reference ? " (reference)" : "") << " | " << k.frames
      << " | " << k.markers << " | " << k.points << " | " << k.points_rejected << " | "
      << Fixed(k.rms_px, 3) << " | " << Fixed(k.rms_normalised, 2) << " | " << Sigmas(k.covariance)
      << " | " << Fixed(AngleBetweenRad(before, k.rig_from_cam) * 1e3, 3) << " | "
      << Fixed((before.tvec - k.rig_from_cam.tvec).norm() * 1e3, 3) << " |\n";
  }
  return t.str();
}

}  // namespace

int RunRigSurvey(const RigSurveyRunOptions& o) {
  for (const auto& [flag, out] : {std::pair{"--out", o.out}, std::pair{"--report", o.report}}) {
    if (out.empty()) continue;
    if (Status s = CheckNotAnInput(flag, out, {o.rig, o.layout, o.frames_list}); !s)
      return BadInput(kProgram, s.message());
  }
  if (!o.report.empty() && std::filesystem::absolute(o.report) == std::filesystem::absolute(o.out))
    return BadInput(kProgram, "--report " + o.report + ": is --out; expected another file name");
  PoseEstimatorOptions options;
  if (o.corner_sigma_px > 0) options.fusion.corner_sigma_px = o.corner_sigma_px;
  options.detector.known_ids_only = true;
  std::unique_ptr<RigPoseEstimator> est;
  if (Status s = RigPoseEstimator::CreateFromFiles(o.rig, {o.layout}, options, &est); !s)
    return BadInput(kProgram, s.message());
  const CameraRig& rig = est->rig();
  const size_t n = est->num_cameras();
  RigSurveyOptions survey;
  survey.measurement = options.fusion;
  for (const RigCamera& c : rig.cameras) survey.camera_names.push_back(c.name);
  if (!o.reference.empty())
    if (Status s = FindRigCamera(rig, o.reference, o.rig, &survey.reference_camera); !s)
      return BadInput(kProgram, "--reference " + o.reference + ": " + s.message());

  // The observations of every listed time stamp.
  std::string list;
  if (Status s = ReadTextFile(o.frames_list, &list); !s) return BadInput(kProgram, s.message());
  const std::filesystem::path base = std::filesystem::path(o.frames_list).parent_path();
  const int64_t max_pixels = static_cast<int64_t>(o.max_megapixels * 1e6);
  std::istringstream lines(list);
  std::vector<RigSurveyFrame> frames;
  std::vector<std::string> paths;
  std::vector<cv::Mat> images(n);
  size_t line_number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::string where = o.frames_list + ", line " + std::to_string(line_number) + ": ";
    double timestamp = static_cast<double>(frames.size());
    std::string error;
    if (!ParseFramesListLine(line, n, base, &timestamp, &paths, &error))
      return BadInput(kProgram, where + error);
    for (size_t c = 0; c < n; ++c) {
      images[c].release();
      if (paths[c].empty()) continue;
      const CameraModel& camera = est->camera(c).camera();
      if (Status s = LoadImage(paths[c], max_pixels, &images[c]); !s)
        return BadInput(kProgram, where + s.message());
      if (images[c].cols != camera.width() || images[c].rows != camera.height())
        return BadInput(kProgram, where + paths[c] + ": " + std::to_string(images[c].cols) + "x" +
                                      std::to_string(images[c].rows) + " pixels, but camera '" +
                                      rig.cameras[c].name + "' is " +
                                      std::to_string(camera.width()) + "x" +
                                      std::to_string(camera.height()));
    }
    frames.push_back(RigSurveyFrameFromImages(*est, images, timestamp));
  }
  if (frames.empty())
    return BadInput(kProgram, o.frames_list + ": no frames (one line per time stamp)");

  RigSurveyResult result;
  if (Status s = SurveyRig(RigSurveyViews(*est), frames, survey, &result); !s) {
    std::cerr << kProgram << ": " << s.message() << "\n";
    return kExitFailed;
  }
  CameraRig out = rig;
  for (size_t c = 0; c < n; ++c) {
    out.cameras[c].rig_from_cam = result.cameras[c].rig_from_cam;
    out.cameras[c].rig_from_cam_covariance = result.cameras[c].covariance;
  }
  const std::string report = Report(o, rig, result, frames.size());
  int rc = kExitOk;
  if (Status s = WriteRigFile(o.out, out); !s) {
    std::cerr << kProgram << ": " << s.message() << "\n";
    rc = kExitFailed;
  }
  if (!o.report.empty())
    if (Status s = WriteTextFile(o.report, report); !s) {
      std::cerr << kProgram << ": " << s.message() << "\n";
      rc = kExitFailed;
    }
  if (!o.quiet) std::cerr << report;
  return rc;
}

}  // namespace svms::cli
