#include "detect_batch.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>

#include "cli_io.h"
#include "commands.h"
#include "json_lines.h"
#include "svms/camera/camera_covariance.h"
#include "svms/detect/detector.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/mrcal_uncertainty.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/overlay.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/response_check.h"
#include "svms/pipelines/video_frames.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;

// What every image of the batch is measured with, and what the batch has found so far.
struct Batch {
  explicit Batch(const DetectOptions& options) : o(options) {}
  const DetectOptions& o;
  CameraModel camera;
  Photometry photometry;
  std::vector<MarkerModel> models;
  std::set<int> model_ids;  // the models' IDs, inner markers' included
  std::unique_ptr<Detector> detector;
  std::vector<std::string> files;  // the inputs, expanded
  int64_t max_pixels = 0;
  std::vector<std::string> errors;  // per file: "" or why it failed
  std::mutex warnings_mutex;
  std::atomic<int> checked_responses{0};
  std::string stdout_error;  // the first failed write to standard output
};

// Everything checked before any work: the camera, photometry, models, inputs and outputs (none
// may replace an input, and no two inputs may write the same overlay). kExitOk to go on.
int Prepare(Batch* b) {
  const DetectOptions& o = b->o;
  if (!o.camera.empty()) {
    if (Status s = ReadCameraWithSidecar(o.camera, &b->camera); !s)
      return BadInput("svms detect", s.message());
    if (std::string hint = MissingUncertaintyHint(o.camera); !hint.empty() && !o.quiet)
      std::cerr << "svms detect: " << hint << "\n";
  }
  if (Status s = Photometry::Create(o.photometry, o.camera, &b->photometry); !s)
    return BadInput("svms detect", s.message());
  if (!o.markers.empty()) {
    ModelFile f;
    if (Status s = ReadModelFile(o.markers, &f); !s) return BadInput("svms detect", s.message());
    b->models = f.markers;
  }
  b->files = ExpandImageInputs(o.inputs);
  if (b->files.empty())
    return BadInput(
        "svms detect",
        "no image files in the inputs (directories are searched for .png, .jpg, .jpeg, .tif, "
        ".tiff, .bmp, .pgm, .ppm)");
  if (!o.overlay.empty()) {
    if (Status s = PrepareOutputDirectory("--overlay", o.overlay); !s)
      return BadInput("svms detect", s.message());
    if (Status s = CheckOverlayTargets(o.overlay, b->files); !s)
      return BadInput("svms detect", s.message());
  }
  if (!o.debug.empty()) {
    if (Status s = PrepareOutputDirectory("--debug", o.debug); !s)
      return BadInput("svms detect", s.message());
    for (const char* picture : {"1_segments.png", "2_quads.png"})
      if (Status s = CheckNotAnInput("--debug", (fs::path(o.debug) / picture).string(), b->files);
          !s)
        return BadInput("svms detect", s.message());
  }
  // LoadStoredImage refuses absurd images from their headers before decoding them; OpenCV's
  // own limit (read once, at its first use) is a second line.
  b->max_pixels = static_cast<int64_t>(std::llround(o.max_megapixels * 1e6));
  setenv("OPENCV_IO_MAX_IMAGE_PIXELS", std::to_string(b->max_pixels).c_str(), 1);
  DetectorOptions dopt;
  dopt.debug_pictures = !o.debug.empty();
  dopt.threads = o.frame_threads;
  dopt.decimate = o.decimate;
  dopt.refine.max_row_window_px = b->photometry.CornerRowWindowPx();
  b->detector = std::make_unique<Detector>(dopt, b->camera, b->models);
  for (const MarkerModel& m : b->models) {
    b->model_ids.insert(m.id);
    if (m.inner) b->model_ids.insert(m.inner->id);
  }
  b->errors.assign(b->files.size(), "");
  return kExitOk;
}

// One linear image (of `name`, frame `frame` of a video or -1) into its JSON line `j`, its
// detections into *found_out (optional); the first failure in *error.
// `noise`: a raw frame's noise from its stored values (Photometry::Load), when valid.
void Measure(Batch& b, const cv::Mat& linear, const NoiseModel& noise, const std::string& name,
             int frame, nlohmann::json* j, std::string* error,
             std::vector<Detection>* found_out = nullptr) {
  const CameraModel& camera = b.camera;
  if (linear.cols < 16 || linear.rows < 16) {
    *error = name + ": " + std::to_string(linear.cols) + "x" + std::to_string(linear.rows) +
             " pixels is too small to hold a marker (at least 16x16 expected)";
    return;
  }
  if (!camera.empty() && (linear.cols != camera.width() || linear.rows != camera.height())) {
    *error = name + ": " + std::to_string(linear.cols) + "x" + std::to_string(linear.rows) +
             " pixels, but the camera model is " + std::to_string(camera.width()) + "x" +
             std::to_string(camera.height());
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  DetectionStats stats;
  std::vector<Detection> found;
  b.detector->Detect(linear, &stats, std::chrono::steady_clock::time_point::max(), &found,
                     noise.valid() ? &noise : nullptr);
  (*j)["ms"] =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json ds = nlohmann::json::array();
  for (const Detection& d : found) {
    nlohmann::json dj = DetectionJson(d);
    if (!camera.empty() && !d.cam_from_marker && d.pose_error.empty())
      dj["pose_error"] = b.model_ids.count(d.id)
                             ? "no pose"
                             : "no marker model for this ID (--markers): its size is unknown";
    ds.push_back(dj);
  }
  (*j)["detections"] = ds;
  if (found_out) *found_out = found;
  for (const auto& [step, picture] : stats.debug_pictures)
    if (Status w = WriteImage((fs::path(b.o.debug) / (step + ".png")).string(), picture); !w)
      *error = "--debug: " + w.message();
  if (!b.o.overlay.empty()) {
    cv::Mat bgr = DisplayImage(linear);
    DrawOverlay(bgr, found);
    if (Status w = WriteImage(OverlayPath(b.o.overlay, name, frame), bgr); !w)
      *error = "--overlay: " + w.message();
  }
}

// Image file i: its JSON line; a failure in b.errors[i].
std::string ProcessImage(Batch& b, size_t i) {
  const std::string& f = b.files[i];
  nlohmann::json j;
  SetPath(j, "image", f);
  cv::Mat linear, stored;
  NoiseModel noise;
  nlohmann::json photometric;
  try {
    std::vector<Detection> found;
    if (Status s = b.photometry.Load(f, b.max_pixels, &linear, &photometric, &stored, &noise); !s)
      b.errors[i] = s.message();
    else
      Measure(b, linear, noise, f, -1, &j, &b.errors[i], &found);
    if (!photometric.is_null()) {
      // A response not declared by the file itself is checked against the image's edges, on
      // the first few images of the run (it is a setting of the run, and the check costs a
      // few milliseconds).
      if (photometric["source"] != "image" && !found.empty() && b.checked_responses++ < 8) {
        const std::string warning = CheckDeclaredResponse(stored, found, photometric);
        if (!warning.empty()) {
          photometric["warning"] = warning;
          std::lock_guard<std::mutex> lock(b.warnings_mutex);
          std::cerr << "svms detect: " << f << ": warning: " << warning << "\n";
        }
      }
      j["photometry"] = photometric;
    }
  } catch (...) {
    b.errors[i] = ItemFailure(f, std::current_exception());
  }
  if (!b.errors[i].empty()) j["error"] = b.errors[i];
  return DumpJson(j);
}

// Video file i, frame by frame in order, one line per frame (with its frame index and the
// container's time stamp), streamed. Returns the frames that failed; *unopenable when the
// video could not be opened.
int ProcessVideo(Batch& b, size_t i, bool* unopenable) {
  const std::string& file = b.files[i];
  VideoFrames video;
  if (Status s = video.Open(file); !s) {
    *unopenable = true;
    b.errors[i] = s.message();
    nlohmann::json j;
    SetPath(j, "image", file);
    j["error"] = b.errors[i];
    WriteStdout(DumpJson(j) + "\n", false, &b.stdout_error);
    return 0;
  }
  int failed = 0;
  cv::Mat frame, linear;
  double t = 0;
  int index = 0, frames = 0;
  while (b.stdout_error.empty() && video.Next(&frame, &t, &index)) {
    ++frames;
    nlohmann::json j, photometric;
    SetPath(j, "image", file);
    j["frame"] = index;
    j["timestamp"] = t;
    std::string error;
    NoiseModel noise;
    if (Status s = b.photometry.LinearizeFrame(frame, "srgb", &linear, &photometric, &noise); !s)
      error = file + ", frame " + std::to_string(index) + ": " + s.message();
    else
      Measure(b, linear, noise, file, index, &j, &error);
    j["photometry"] = photometric;
    if (!error.empty()) {
      j["error"] = error;
      std::cerr << "svms detect: " << error << "\n";
      ++failed;
    }
    WriteStdout(DumpJson(j) + "\n", false, &b.stdout_error);
  }
  if (frames == 0) b.errors[i] = file + ": the video has no frames";
  if (std::string e = video.Incomplete(frames); !e.empty()) b.errors[i] = e;
  return failed;
}

// Image files only: in parallel on o.threads threads. Lines go out in input order as soon as
// every earlier image is done, so that memory does not grow with the batch (only the errors are
// kept for the summary).
void ProcessImagesInParallel(Batch& b) {
  const size_t n = b.files.size();
  std::vector<std::string> lines(n);
  std::vector<bool> ready(n, false);
  size_t printed = 0;
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress progress("svms detect:", n, " images", !b.o.quiet && n > 1);
  auto worker = [&] {
    for (size_t i; (i = next++) < n;) {
      std::string line = ProcessImage(b, i);
      std::lock_guard<std::mutex> lock(io);
      lines[i] = std::move(line);
      ready[i] = true;
      for (; printed < n && ready[printed]; ++printed) {
        WriteStdout(lines[printed] + "\n", false, &b.stdout_error);
        std::string().swap(lines[printed]);
      }
      progress.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, std::min<int>(b.o.threads, static_cast<int>(n))); ++t)
    pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  progress.Finish();
}

}  // namespace

int RunDetect(const DetectOptions& o) {
  Batch b(o);
  if (const int rc = Prepare(&b); rc != kExitOk) return rc;
  const bool any_video = std::any_of(b.files.begin(), b.files.end(), IsVideoFile);
  int failed = 0;
  bool unopenable_video = false;  // bad input: exit 2 at the end
  if (any_video) {
    // With a video among the inputs everything runs on this thread, in order.
    for (size_t i = 0; i < b.files.size() && b.stdout_error.empty(); ++i) {
      if (IsVideoFile(b.files[i]))
        failed += ProcessVideo(b, i, &unopenable_video);
      else
        WriteStdout(ProcessImage(b, i) + "\n", false, &b.stdout_error);
    }
  } else {
    ProcessImagesInParallel(b);
  }
  WriteStdout("", true, &b.stdout_error);
  for (const std::string& e : b.errors)
    if (!e.empty()) {
      std::cerr << "svms detect: " << e << "\n";
      ++failed;
    }
  if (failed)
    std::cerr << "svms detect: " << failed << " of " << b.files.size()
              << (any_video ? " inputs failed\n" : " images failed\n");
  if (!b.stdout_error.empty()) {
    std::cerr << "svms detect: " << b.stdout_error << "; the results are lost\n";
    return kExitFailed;
  }
  if (unopenable_video) return kExitBadInput;
  return failed ? kExitFailed : kExitOk;
}

}  // namespace svms::cli
