#include "pose_stream.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli_io.h"
#include "commands.h"
#include "json_lines.h"
#include "svms/base/file_io.h"
#include "svms/camera/camera_covariance.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/mrcal_uncertainty.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/overlay.h"
#include "svms/pipelines/video_frames.h"

namespace svms::cli {
namespace {

// What a line calls the object of a layout: the layout's own `name`, else its file's stem.
std::string ObjectName(const Layout& layout, const std::string& path) {
  return layout.name.empty() ? std::filesystem::path(path).stem().string() : layout.name;
}

// The estimator and what the stream has done so far.
struct Stream {
  explicit Stream(const PoseOptions& options) : o(options) {}
  const PoseOptions& o;
  std::unique_ptr<PoseEstimator> est;
  Photometry photometry;
  std::vector<std::string> files;  // the inputs, expanded (none with --stdin)
  int64_t max_pixels = 0;
  size_t index = 0, failed = 0, valid = 0;  // frames so far
  bool unopenable_video = false;            // bad input: exit 2 at the end
  std::string first_error, stdout_error;
  FrameResult r;
  std::vector<std::string> object_names;  // per layout: its `name`, else its file's stem
};

// Everything checked before any work: the inputs, the estimator (camera and layout), the
// photometry, the overlay directory. kExitOk to go on.
int Prepare(Stream* s) {
  const PoseOptions& o = s->o;
  if (o.from_stdin == !o.inputs.empty())
    return BadInput(
        "svms pose",
        "give IMAGES or --stdin (a path, and optionally a timestamp in seconds, per line), not "
        "both and not neither");
  if (Status st = Photometry::Create(o.photometry, o.camera, &s->photometry); !st)
    return BadInput("svms pose", st.message());
  PoseEstimatorOptions options;
  options.fusion.corner_sigma_px = o.corner_sigma_px;
  options.budget_ms = o.budget_ms;
  options.detector.threads = o.frame_threads;
  options.detector.decimate = o.decimate;
  options.detector.refine.max_row_window_px = s->photometry.CornerRowWindowPx();
  options.detector.known_ids_only = !o.unknown_ids;
  if (o.layouts.empty()) return BadInput("svms pose", "--layout: expected a layout file");
  if (Status st = o.layouts.size() == 1
                      ? PoseEstimator::CreateFromFiles(o.camera, o.layouts[0], options, &s->est)
                      : PoseEstimator::CreateFromFiles(o.camera, o.layouts, options, &s->est);
      !st)
    return BadInput("svms pose", st.message());
  for (size_t i = 0; i < o.layouts.size(); ++i)
    s->object_names.push_back(ObjectName(s->est->layouts()[i], o.layouts[i]));
  if (!o.from_stdin) s->files = ExpandImageInputs(o.inputs);
  if (!o.overlay.empty()) {
    if (Status st = PrepareOutputDirectory("--overlay", o.overlay); !st)
      return BadInput("svms pose", st.message());
    if (Status st = CheckOverlayTargets(o.overlay, s->files); !st)
      return BadInput("svms pose", st.message());
  }
  // LoadImage refuses absurd images from their headers; OpenCV's own limit is a second line.
  s->max_pixels = static_cast<int64_t>(o.max_megapixels * 1e6);
  const std::string limit = std::to_string(s->max_pixels);
  setenv("OPENCV_IO_MAX_IMAGE_PIXELS", limit.c_str(), 1);
  if (!o.quiet) {
    std::cerr << "svms pose: " << o.camera << ": "
              << (s->est->camera().intrinsics_covariance_factor().size() > 0
                      ? "its calibration's uncertainty (" + CovarianceSidecarPath(o.camera) +
                            ") goes into the pose covariance\n"
                      : "no " + CovarianceSidecarPath(o.camera) +
                            ": the pose covariance leaves out the calibration's error\n");
    if (std::string hint = MissingUncertaintyHint(o.camera); !hint.empty())
      std::cerr << "svms pose: " << hint << "\n";
  }
  return kExitOk;
}

// One frame: read (from `path`, or the decoded video frame `video_frame`), estimate, print
// (flushed, so that a reader of the pipe sees it now). `error` set: the frame failed before.
void Frame(Stream& s, const std::string& path, double timestamp, std::string error,
           const cv::Mat* video_frame = nullptr, int frame_index = -1) {
  const CameraModel& camera = s.est->camera();
  const size_t objects = s.o.layouts.size();
  std::vector<nlohmann::json> lines(objects);  // one per object
  nlohmann::json photometric;
  cv::Mat img;
  NoiseModel noise;  // a raw frame's, from its stored values (as PoseEstimator::Estimate)
  if (!error.empty()) {
  } else if (Status st =
                 video_frame
                     ? s.photometry.LinearizeFrame(*video_frame, "srgb", &img, &photometric, &noise)
                     : s.photometry.Load(path, s.max_pixels, &img, &photometric, nullptr, &noise);
             !st) {
    error = video_frame ? path + ", frame " + std::to_string(frame_index) + ": " + st.message()
                        : st.message();
  } else if (img.cols != camera.width() || img.rows != camera.height()) {
    error = path + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
            " pixels, but the camera model is " + std::to_string(camera.width()) + "x" +
            std::to_string(camera.height());
  }
  if (error.empty()) {
    try {
      s.est->EstimateLinear(img, timestamp, &s.r, noise.valid() ? &noise : nullptr);
      for (size_t i = 0; i < objects; ++i) {
        lines[i] = FrameJson(s.r, i);
        if (s.o.unknown_ids || objects > 1) lines[i]["unassigned_markers"] = s.r.unassigned_ids;
      }
      bool any_valid = false;
      for (size_t i = 0; i < objects; ++i) any_valid |= s.r.object(i).valid;
      s.valid += any_valid;
      if (!s.o.overlay.empty()) {
        const std::string out = OverlayPath(s.o.overlay, path, frame_index);
        if (SameFile(out, path)) {
          error = "--overlay " + out + ": is the input " + path + "; expected a new file name";
        } else {
          cv::Mat bgr = DisplayImage(img);
          DrawOverlay(bgr, s.r.detections);
          if (Status w = WriteImage(out, bgr); !w) error = "--overlay: " + w.message();
        }
      }
    } catch (...) {
      for (nlohmann::json& j : lines) j = nlohmann::json::object();
      error = ItemFailure(path, std::current_exception());
    }
  }
  std::string text;
  for (size_t i = 0; i < objects; ++i) {
    nlohmann::json& j = lines[i];
    SetPath(j, "image", path);
    if (objects > 1) {
      j["object"] = s.object_names[i];
      SetPath(j, "layout", s.o.layouts[i]);
    }
    if (frame_index >= 0) j["frame"] = frame_index;
    if (!photometric.is_null()) j["photometry"] = photometric;
    if (!error.empty()) {
      j["timestamp"] = timestamp;
      if (!j.contains("valid")) j["valid"] = false;
      j["error"] = error;
    }
    text += DumpJson(j) + "\n";
  }
  if (!error.empty()) {
    std::cerr << "svms pose: " << error << "\n";
    if (s.first_error.empty()) s.first_error = error;
    ++s.failed;
  }
  // The frame's lines in one write: a reader of the pipe sees all its objects at once.
  WriteStdout(text, true, &s.stdout_error);
  ++s.index;
  if (!s.o.quiet && s.index % 50 == 0)
    std::cerr << "svms pose: " << s.index << " frames, " << s.valid << " with a pose\n";
}

// A video: every frame, with the container's time stamp.
void Video(Stream& s, const std::string& path) {
  VideoFrames v;
  if (Status st = v.Open(path); !st) {
    s.unopenable_video = true;
    return Frame(s, path, static_cast<double>(s.index), st.message());
  }
  cv::Mat f;
  double t = 0;
  int i = 0, frames = 0;
  while (s.stdout_error.empty() && v.Next(&f, &t, &i)) Frame(s, path, t, "", &f, i), ++frames;
  if (frames == 0) Frame(s, path, static_cast<double>(s.index), path + ": the video has no frames");
  if (std::string e = v.Incomplete(frames); !e.empty()) Frame(s, path, t, e);
}

// --stdin: "PATH" or "PATH TIMESTAMP" per line (the last field, if it parses as a number), a
// video's frames for a video's path.
void ReadStdin(Stream& s) {
  std::string line;
  bool too_long = false;
  size_t line_number = 0;
  while (s.stdout_error.empty() && ReadBoundedLine(stdin, kMaxStdinLineBytes, &line, &too_long)) {
    ++line_number;
    if (too_long) {
      Frame(s, line.substr(0, 64) + "...", static_cast<double>(s.index),
            "standard input, line " + std::to_string(line_number) + ": longer than " +
                std::to_string(kMaxStdinLineBytes) +
                " bytes; expected PATH [TIMESTAMP] on each line");
      continue;
    }
    if (line.empty()) continue;
    std::string path = line;
    double timestamp = static_cast<double>(s.index);
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
      Video(s, path);
    else
      Frame(s, path, timestamp, "");
  }
}

}  // namespace

int RunPose(const PoseOptions& o) {
  Stream s(o);
  if (const int rc = Prepare(&s); rc != kExitOk) return rc;
  if (o.from_stdin) {
    ReadStdin(s);
  } else {
    for (const std::string& f : s.files) {
      if (!s.stdout_error.empty()) break;
      if (IsVideoFile(f))
        Video(s, f);
      else
        Frame(s, f, static_cast<double>(s.index), "");
    }
  }
  if (!o.quiet)
    std::cerr << "svms pose: " << s.index << " frames, " << s.valid << " with a pose, " << s.failed
              << " unreadable\n";
  if (!s.stdout_error.empty()) {
    std::cerr << "svms pose: " << s.stdout_error << "; stopped after " << s.index << " frames\n";
    return kExitFailed;
  }
  if (s.failed) {
    std::cerr << "svms pose: " << s.failed << " of " << s.index
              << " frames failed (first: " << s.first_error << ")\n";
    return s.unopenable_video ? kExitBadInput : kExitFailed;
  }
  return kExitOk;
}

}  // namespace svms::cli
