// svms pose: the fused object pose of every frame, streamed as JSON Lines.
#include <Eigen/Geometry>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "cli_io.h"
#include "commands.h"
#include "photometry_options.h"
#include "svms/base/file_io.h"
#include "svms/camera/camera_covariance.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/overlay.h"
#include "svms/pipelines/photometry.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/video_frames.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;

struct PoseCliOptions {
  std::vector<std::string> inputs;
  std::string camera, layout, overlay;
  bool from_stdin = false;
  bool quiet = false;
  double corner_sigma_px = ObjectPoseOptions{}.corner_sigma_px;
  double budget_ms = 0;
  double max_megapixels = 100;
  PhotometryOptions photometry;
};

// {rvec, tvec, quaternion [w, x, y, z]} of a pose.
nlohmann::json PoseJson(const Pose& pose) {
  const Eigen::Quaterniond q(pose.Rotation());
  return {{"rvec", {pose.rvec(0), pose.rvec(1), pose.rvec(2)}},
          {"tvec", {pose.tvec(0), pose.tvec(1), pose.tvec(2)}},
          {"quaternion", {q.w(), q.x(), q.y(), q.z()}}};
}

}  // namespace

nlohmann::json FrameJson(const FrameResult& r) {
  const ObjectPose& p = r.pose;
  nlohmann::json j;
  j["timestamp"] = r.timestamp;
  j["valid"] = p.valid;
  if (p.valid) {
    j["cam_from_object"] = PoseJson(p.cam_from_object);
    std::vector<double> cov(36);
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) cov[a * 6 + b] = p.covariance(a, b);
    j["covariance"] = cov;
    if (p.alternative_cam_from_object) {
      j["alternative"] = PoseJson(*p.alternative_cam_from_object);
      j["alternative"]["weight"] = p.alternative_weight;
    }
  } else {
    j["cam_from_object"] = nullptr;
    j["covariance"] = nullptr;
    j["message"] = p.message;
  }
  j["markers"] = p.ids_used;
  j["markers_rejected"] = p.ids_rejected;
  j["points_rejected"] = p.points_rejected;
  j["markers_seen"] = p.markers_seen;
  j["points"] = p.points_used;
  j["rms"] = p.rms_px;
  j["chi2"] = p.chi2;
  j["dof"] = p.dof;
  j["flags"] = {{"ambiguous", p.ambiguous},
                {"poorly_conditioned", p.poorly_conditioned},
                {"budget_exceeded", r.budget_exceeded},
                {"calibration_in_covariance", p.calibration_in_covariance}};
  j["latency_ms"] = r.latency_ms;
  j["detect_ms"] = r.detect_ms;
  return j;
}

namespace {

int RunPose(const PoseCliOptions& o) {
  auto bad_input = [](const std::string& m) {
    std::cerr << "svms pose: " << m << "\n";
    return kExitBadInput;
  };
  if (o.from_stdin == !o.inputs.empty())
    return bad_input(
        "give IMAGES or --stdin (a path, and optionally a timestamp in seconds, per line), not "
        "both and not neither");
  PoseEstimatorOptions options;
  options.fusion.corner_sigma_px = o.corner_sigma_px;
  options.budget_ms = o.budget_ms;
  std::unique_ptr<PoseEstimator> est;
  if (Status s = PoseEstimator::CreateFromFiles(o.camera, o.layout, options, &est); !s)
    return bad_input(s.message());
  Photometry photometry;
  if (Status s = Photometry::Create(o.photometry, o.camera, &photometry); !s)
    return bad_input(s.message());
  std::vector<std::string> files;
  if (!o.from_stdin) files = ExpandImageInputs(o.inputs);
  if (!o.overlay.empty()) {
    if (Status s = PrepareOutputDirectory("--overlay", o.overlay); !s)
      return bad_input(s.message());
    if (Status s = CheckOverlayTargets(o.overlay, files); !s) return bad_input(s.message());
  }
  // LoadImage refuses absurd images from their headers; OpenCV's own limit is a second line.
  const int64_t max_pixels = static_cast<int64_t>(o.max_megapixels * 1e6);
  const std::string limit = std::to_string(max_pixels);
  setenv("OPENCV_IO_MAX_IMAGE_PIXELS", limit.c_str(), 1);
  const CameraModel& camera = est->camera();
  if (!o.quiet) {
    std::cerr << "svms pose: " << o.camera << ": "
              << (camera.intrinsics_covariance_factor().size() > 0
                      ? "its calibration's uncertainty (" + CovarianceSidecarPath(o.camera) +
                            ") goes into the pose covariance\n"
                      : "no " + CovarianceSidecarPath(o.camera) +
                            ": the pose covariance leaves out the calibration's error\n");
  }

  size_t index = 0, failed = 0, valid = 0;
  bool unopenable_video = false;  // bad input: exit 2 at the end
  std::string first_error, stdout_error;
  FrameResult r;
  // One frame: read (from `path`, or the decoded video frame `frame`), estimate, print (flushed,
  // so that a reader of the pipe sees it now).
  auto frame = [&](const std::string& path, double timestamp, std::string error,
                   const cv::Mat* video_frame = nullptr, int frame_index = -1) {
    nlohmann::json j, photometric;
    cv::Mat img;
    if (!error.empty()) {
    } else if (Status s = video_frame
                              ? photometry.LinearizeFrame(*video_frame, "srgb", &img, &photometric)
                              : photometry.Load(path, max_pixels, &img, &photometric);
               !s) {
      error = video_frame ? path + ", frame " + std::to_string(frame_index) + ": " + s.message()
                          : s.message();
    } else if (img.cols != camera.width() || img.rows != camera.height()) {
      error = path + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
              " pixels, but the camera model is " + std::to_string(camera.width()) + "x" +
              std::to_string(camera.height());
    }
    if (error.empty()) {
      try {
        est->EstimateLinear(img, timestamp, &r);
        j = FrameJson(r);
        valid += r.pose.valid;
        if (!o.overlay.empty()) {
          const std::string out = OverlayPath(o.overlay, path, frame_index);
          if (SameFile(out, path)) {
            error = "--overlay " + out + ": is the input " + path + "; expected a new file name";
          } else {
            cv::Mat bgr = DisplayImage(img);
            DrawOverlay(bgr, r.detections);
            if (Status w = WriteImage(out, bgr); !w) error = "--overlay: " + w.message();
          }
        }
      } catch (...) {
        j = nlohmann::json::object();
        error = ItemFailure(path, std::current_exception());
      }
    }
    SetPath(j, "image", path);
    if (frame_index >= 0) j["frame"] = frame_index;
    if (!photometric.is_null()) j["photometry"] = photometric;
    if (!error.empty()) {
      j["timestamp"] = timestamp;
      if (!j.contains("valid")) j["valid"] = false;
      j["error"] = error;
      std::cerr << "svms pose: " << error << "\n";
      if (first_error.empty()) first_error = error;
      ++failed;
    }
    WriteStdout(DumpJson(j) + "\n", true, &stdout_error);
    ++index;
    if (!o.quiet && index % 50 == 0)
      std::cerr << "svms pose: " << index << " frames, " << valid << " with a pose\n";
  };
  // A video: every frame, with the container's time stamp.
  auto video = [&](const std::string& path) {
    VideoFrames v;
    if (Status s = v.Open(path); !s) {
      unopenable_video = true;
      return frame(path, static_cast<double>(index), s.message());
    }
    cv::Mat f;
    double t = 0;
    int i = 0, frames = 0;
    while (stdout_error.empty() && v.Next(&f, &t, &i)) frame(path, t, "", &f, i), ++frames;
    if (frames == 0) frame(path, static_cast<double>(index), path + ": the video has no frames");
    if (std::string e = v.Incomplete(frames); !e.empty()) frame(path, t, e);
  };
  if (o.from_stdin) {
    std::string line;
    bool too_long = false;
    size_t line_number = 0;
    while (stdout_error.empty() && ReadBoundedLine(stdin, kMaxStdinLineBytes, &line, &too_long)) {
      ++line_number;
      if (too_long) {
        frame(line.substr(0, 64) + "...", static_cast<double>(index),
              "standard input, line " + std::to_string(line_number) + ": longer than " +
                  std::to_string(kMaxStdinLineBytes) +
                  " bytes; expected PATH [TIMESTAMP] on each line");
        continue;
      }
      if (line.empty()) continue;
      // "PATH" or "PATH TIMESTAMP" (the last field, if it parses as a number).
      std::string path = line;
      double timestamp = static_cast<double>(index);
      const size_t space = line.find_last_of(" \t");
      if (space != std::string::npos) {
        const std::string tail = line.substr(space + 1);
        char* end = nullptr;
        const double t = std::strtod(tail.c_str(), &end);
        if (end && *end == '\0' && !tail.empty() && std::isfinite(t)) {
          timestamp = t;
          path = line.substr(0, line.find_last_not_of(" \t", space) + 1);
        }
      }
      if (IsVideoFile(path))
        video(path);
      else
        frame(path, timestamp, "");
    }
  } else {
    for (const std::string& f : files) {
      if (!stdout_error.empty()) break;
      if (IsVideoFile(f))
        video(f);
      else
        frame(f, static_cast<double>(index), "");
    }
  }
  if (!o.quiet)
    std::cerr << "svms pose: " << index << " frames, " << valid << " with a pose, " << failed
              << " unreadable\n";
  if (!stdout_error.empty()) {
    std::cerr << "svms pose: " << stdout_error << "; stopped after " << index << " frames\n";
    return kExitFailed;
  }
  if (failed) {
    std::cerr << "svms pose: " << failed << " of " << index
              << " frames failed (first: " << first_error << ")\n";
    return unopenable_video ? kExitBadInput : kExitFailed;
  }
  return kExitOk;
}

}  // namespace

void AddPoseCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<PoseCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "pose", "The object's pose in each frame from every visible marker of a surveyed layout");
  cmd->add_option("IMAGES", o->inputs, "Image files, directories or globs (in this order)");
  cmd->add_flag("--stdin", o->from_stdin,
                "Read frames from stdin: a path per line, optionally followed by a timestamp "
                "(seconds)");
  cmd->add_option("--camera", o->camera, "mrcal .cameramodel")->required();
  cmd->add_option("--layout", o->layout, "Surveyed layout (svms survey --out)")->required();
  cmd->add_option("--corner-sigma", o->corner_sigma_px,
                  "Pixel noise of a detected corner, each axis (see docs/flight-interface.md)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--budget-ms", o->budget_ms, "Time budget per frame (0: none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--overlay", o->overlay, "Write overlay PNGs to this directory");
  cmd->add_option("--max-megapixels", o->max_megapixels, "Refuse larger images")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  AddPhotometryOptions(cmd, &o->photometry);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->footer(
      "Output: one JSON line per frame, flushed: image, timestamp (given, or the frame index),\n"
      "valid, cam_from_object {rvec, tvec, quaternion [w, x, y, z]}, covariance (36 numbers,\n"
      "row-major, [rotation, translation], rotation about the camera axes), markers (IDs used),\n"
      "markers_rejected, points_rejected, markers_seen, points, rms (px), chi2, dof, flags "
      "{ambiguous,\n"
      "poorly_conditioned, budget_exceeded, calibration_in_covariance}, latency_ms, detect_ms;\n"
      "alternative {rvec, tvec, quaternion, weight} where ambiguous: the pose under the one\n"
      "marker's other planar pose and its share of the likelihood; message when not valid.\n"
      "The covariance includes the camera calibration's uncertainty\n"
      "when CAMERA.covariance.json (written by svms calibrate) is next to the camera model.\n"
      "An unreadable frame gets an \"error\" field and a line on stderr; the stream goes on;\n"
      "a --stdin line longer than 65536 bytes is such an error. A path that is not valid UTF-8\n"
      "is written with U+FFFD for its bad bytes and its exact bytes in image_hex.\n"
      "exit code 1 at the end. A video file gives every frame, timestamp from the container.\n"
      "photometry: how the frame was turned into linear light (docs/conventions.md).\n"
      "See docs/flight-interface.md.\n"
      "Examples:\n"
      "  svms pose out/approach --camera cam.cameramodel --layout layout.json\n"
      "  ls frames/*.png | svms pose --stdin --camera cam.cameramodel --layout layout.json");
  cmd->callback([o, exit_code] { *exit_code = RunPose(*o); });
}

}  // namespace svms::cli
