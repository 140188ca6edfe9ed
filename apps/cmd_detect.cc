// svms detect: markers in images, one JSON line per image.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <thread>

#include "cli_io.h"
#include "commands.h"
#include "photometry_options.h"
#include "svms/camera/camera_covariance.h"
#include "svms/camera/photometric.h"
#include "svms/detect/detector.h"
#include "svms/detect/response_estimate.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/overlay.h"
#include "svms/pipelines/photometry.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/video_frames.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;

struct DetectOptions {
  std::vector<std::string> inputs;
  std::string camera, markers, overlay, debug;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  double max_megapixels = kDefaultMaxImagePixels / 1e6;
  PhotometryOptions photometry;
  bool quiet = false;
  bool json = true;
};

nlohmann::json PoseJson(const Pose& p) {
  return {{"rvec", {p.rvec(0), p.rvec(1), p.rvec(2)}}, {"tvec", {p.tvec(0), p.tvec(1), p.tvec(2)}}};
}

nlohmann::json DetectionJson(const Detection& d) {
  nlohmann::json c = nlohmann::json::array();
  for (const auto& p : d.corners) c.push_back({p.x(), p.y()});
  nlohmann::json j = {{"id", d.id}, {"corners", c}, {"bit_errors", d.bit_errors}};
  if (d.corner_sigma[0] > 0)
    j["corner_sigma"] = {d.corner_sigma[0], d.corner_sigma[1], d.corner_sigma[2],
                         d.corner_sigma[3]};
  if (d.penumbra_sides[0] || d.penumbra_sides[1] || d.penumbra_sides[2] || d.penumbra_sides[3]) {
    nlohmann::json sides = nlohmann::json::array();
    for (int k = 0; k < 4; ++k)
      if (d.penumbra_sides[k]) sides.push_back(k);
    j["penumbra_sides"] = sides;
  }
  j["tip"] = d.tip ? nlohmann::json{d.tip->pixel.x(), d.tip->pixel.y()} : nlohmann::json();
  if (d.tip) j["tip_sigma"] = d.tip->sigma_px;
  if (d.cam_from_marker) {
    j["cam_from_marker"] = PoseJson(*d.cam_from_marker);
    std::vector<double> cov(36);
    for (int r = 0; r < 6; ++r)
      for (int k = 0; k < 6; ++k) cov[r * 6 + k] = d.covariance(r, k);
    j["covariance"] = cov;
    j["pose_ambiguous"] = d.pose_ambiguous;
    if (d.alternative_pose) {
      j["alternative_pose"] = PoseJson(*d.alternative_pose);
      j["alternative_pose"]["weight"] = d.alternative_weight;
    }
    j["calibration_in_covariance"] = d.calibration_in_covariance;
  }
  if (!d.pose_error.empty()) j["pose_error"] = d.pose_error;
  if (d.nested_in >= 0) j["nested_in"] = d.nested_in;
  return j;
}

// Whether the response `photometric` declares ({"response", "black_level", "white_level"})
// agrees with the edges of the markers found in `stored` (the image as stored): "" when it does
// or when there are too few edges to tell, else a warning naming both (response_estimate.h).
std::string CheckResponse(const cv::Mat& stored, const std::vector<Detection>& found,
                          const nlohmann::json& photometric) {
  if (photometric.contains("bayer")) return "";  // a mosaic's edges are the demosaic's
  std::vector<EdgeProfile> profiles;
  CollectEdgeProfiles(stored, found, photometric["black_level"].get<double>(),
                      photometric["white_level"].get<double>(), &profiles, 80);
  const ResponseEstimate e = EstimateGammaFromEdges(profiles);
  if (e.profiles == 0) return "";
  Response declared;
  if (!Response::Parse(photometric["response"].get<std::string>(), &declared).ok()) return "";
  // The declared curve's gamma: sRGB is close to 2.2; a table is not checked.
  double g = 1;
  if (declared.kind() == Response::Kind::kSrgb) g = 2.2;
  if (declared.kind() == Response::Kind::kGamma) g = declared.gamma();
  if (declared.kind() == Response::Kind::kTable) return "";
  if (std::abs(e.gamma - g) <= std::max(0.4, 4 * e.sigma)) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "the response %s contradicts the image: the markers' edges (%d profiles) say "
                "gamma %.2f +- %.2f; expected --response gamma:%.1f, or srgb for a camera's "
                "JPEG (docs/detector.md)",
                photometric["response"].get<std::string>().c_str(), e.profiles, e.gamma, e.sigma,
                e.gamma);
  return buf;
}

int RunDetect(const DetectOptions& o) {
  auto bad_input = [](const std::string& m) {
    std::cerr << "svms detect: " << m << "\n";
    return kExitBadInput;
  };
  CameraModel camera;
  if (!o.camera.empty()) {
    if (Status s = ReadCameraWithSidecar(o.camera, &camera); !s) return bad_input(s.message());
  }
  Photometry photometry;
  if (Status s = Photometry::Create(o.photometry, o.camera, &photometry); !s)
    return bad_input(s.message());
  std::vector<MarkerModel> models;
  if (!o.markers.empty()) {
    ModelFile f;
    if (Status s = ReadModelFile(o.markers, &f); !s) return bad_input(s.message());
    models = f.markers;
  }
  const std::vector<std::string> files = ExpandImageInputs(o.inputs);
  if (files.empty())
    return bad_input(
        "no image files in the inputs (directories are searched for .png, .jpg, .jpeg, .tif, "
        ".tiff, .bmp, .pgm, .ppm)");
  const bool any_video = std::any_of(files.begin(), files.end(), IsVideoFile);
  // Outputs are checked before any work: none may replace an input, and no two inputs may
  // write the same overlay.
  if (!o.overlay.empty()) {
    if (Status s = PrepareOutputDirectory("--overlay", o.overlay); !s)
      return bad_input(s.message());
    if (Status s = CheckOverlayTargets(o.overlay, files); !s) return bad_input(s.message());
  }
  if (!o.debug.empty()) {
    if (Status s = PrepareOutputDirectory("--debug", o.debug); !s) return bad_input(s.message());
    for (const char* picture : {"1_segments.png", "2_quads.png"})
      if (Status s = CheckNotAnInput("--debug", (fs::path(o.debug) / picture).string(), files); !s)
        return bad_input(s.message());
  }
  // LoadStoredImage refuses absurd images from their headers before decoding them; OpenCV's
  // own limit (read once, at its first use) is a second line.
  const auto max_pixels = static_cast<int64_t>(std::llround(o.max_megapixels * 1e6));
  setenv("OPENCV_IO_MAX_IMAGE_PIXELS", std::to_string(max_pixels).c_str(), 1);

  DetectorOptions dopt;
  dopt.debug_pictures = !o.debug.empty();
  const Detector detector(dopt, camera, models);
  std::set<int> model_ids;
  for (const MarkerModel& m : models) {
    model_ids.insert(m.id);
    if (m.inner) model_ids.insert(m.inner->id);
  }
  // One linear image (of `name`, frame `frame` of a video or -1) into its JSON line `j`; the
  // first failure in *error.
  auto measure = [&](const cv::Mat& linear, const std::string& name, int frame, nlohmann::json* j,
                     std::string* error, std::vector<Detection>* found_out = nullptr) {
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
    const std::vector<Detection> found = detector.Detect(linear, &stats);
    (*j)["ms"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    nlohmann::json ds = nlohmann::json::array();
    for (const Detection& d : found) {
      nlohmann::json dj = DetectionJson(d);
      if (!camera.empty() && !d.cam_from_marker && d.pose_error.empty())
        dj["pose_error"] = model_ids.count(d.id)
                               ? "no pose"
                               : "no marker model for this ID (--markers): its size is unknown";
      ds.push_back(dj);
    }
    (*j)["detections"] = ds;
    if (found_out) *found_out = found;
    for (const auto& [step, picture] : stats.debug_pictures)
      if (Status w = WriteImage((fs::path(o.debug) / (step + ".png")).string(), picture); !w)
        *error = "--debug: " + w.message();
    if (!o.overlay.empty()) {
      cv::Mat bgr = DisplayImage(linear);
      DrawOverlay(bgr, found);
      if (Status w = WriteImage(OverlayPath(o.overlay, name, frame), bgr); !w)
        *error = "--overlay: " + w.message();
    }
  };
  // One image file: its JSON line; a failure in errors[i].
  std::vector<std::string> errors(files.size());
  std::mutex warnings_mutex;
  std::atomic<int> checked_responses{0};
  auto process = [&](size_t i) {
    const std::string& f = files[i];
    nlohmann::json j;
    SetPath(j, "image", f);
    cv::Mat linear, stored;
    nlohmann::json photometric;
    try {
      std::vector<Detection> found;
      if (Status s = photometry.Load(f, max_pixels, &linear, &photometric, &stored); !s)
        errors[i] = s.message();
      else
        measure(linear, f, -1, &j, &errors[i], &found);
      if (!photometric.is_null()) {
        // A response not declared by the file itself is checked against the image's edges, on
        // the first few images of the run (it is a setting of the run, and the check costs a
        // few milliseconds).
        if (photometric["source"] != "image" && !found.empty() && checked_responses++ < 8) {
          const std::string warning = CheckResponse(stored, found, photometric);
          if (!warning.empty()) {
            photometric["warning"] = warning;
            std::lock_guard<std::mutex> lock(warnings_mutex);
            std::cerr << "svms detect: " << f << ": warning: " << warning << "\n";
          }
        }
        j["photometry"] = photometric;
      }
    } catch (...) {
      errors[i] = ItemFailure(f, std::current_exception());
    }
    if (!errors[i].empty()) j["error"] = errors[i];
    return DumpJson(j);
  };

  std::string stdout_error;  // under io
  int failed = 0;
  bool unopenable_video = false;  // bad input: exit 2 at the end
  size_t units = files.size();
  if (any_video) {
    // Videos are read frame by frame in order, one line per frame (with its frame index and
    // the container's time stamp), streamed; everything on this thread.
    for (size_t i = 0; i < files.size() && stdout_error.empty(); ++i) {
      if (!IsVideoFile(files[i])) {
        WriteStdout(process(i) + "\n", false, &stdout_error);
        continue;
      }
      VideoFrames video;
      if (Status s = video.Open(files[i]); !s) {
        unopenable_video = true;
        errors[i] = s.message();
        nlohmann::json j;
        SetPath(j, "image", files[i]);
        j["error"] = errors[i];
        WriteStdout(DumpJson(j) + "\n", false, &stdout_error);
        continue;
      }
      cv::Mat frame, linear;
      double t = 0;
      int index = 0, frames = 0;
      while (stdout_error.empty() && video.Next(&frame, &t, &index)) {
        ++frames;
        nlohmann::json j, photometric;
        SetPath(j, "image", files[i]);
        j["frame"] = index;
        j["timestamp"] = t;
        std::string error;
        if (Status s = photometry.LinearizeFrame(frame, "srgb", &linear, &photometric); !s)
          error = files[i] + ", frame " + std::to_string(index) + ": " + s.message();
        else
          measure(linear, files[i], index, &j, &error);
        j["photometry"] = photometric;
        if (!error.empty()) {
          j["error"] = error;
          std::cerr << "svms detect: " << error << "\n";
          ++failed;
        }
        WriteStdout(DumpJson(j) + "\n", false, &stdout_error);
      }
      if (frames == 0) errors[i] = files[i] + ": the video has no frames";
      if (std::string e = video.Incomplete(frames); !e.empty()) errors[i] = e;
    }
  } else {
    std::vector<std::string> lines(files.size());
    std::vector<bool> ready(files.size(), false);
    size_t printed = 0;
    std::atomic<size_t> next{0};
    size_t done = 0;  // under io
    std::mutex io;
    Progress progress("svms detect:", files.size(), " images", !o.quiet && files.size() > 1);
    auto worker = [&] {
      for (size_t i; (i = next++) < files.size();) {
        std::string line = process(i);
        std::lock_guard<std::mutex> lock(io);
        // Lines go out in input order as soon as every earlier image is done, so that memory
        // does not grow with the batch (only the errors are kept for the summary).
        lines[i] = std::move(line);
        ready[i] = true;
        for (; printed < files.size() && ready[printed]; ++printed) {
          WriteStdout(lines[printed] + "\n", false, &stdout_error);
          std::string().swap(lines[printed]);
        }
        progress.Update(++done);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::max(1, std::min<int>(o.threads, static_cast<int>(files.size()))); ++t)
      pool.emplace_back(worker);
    for (auto& t : pool) t.join();
    progress.Finish();
  }
  WriteStdout("", true, &stdout_error);
  for (const std::string& e : errors)
    if (!e.empty()) {
      std::cerr << "svms detect: " << e << "\n";
      ++failed;
    }
  if (failed)
    std::cerr << "svms detect: " << failed << " of " << units
              << (any_video ? " inputs failed\n" : " images failed\n");
  if (!stdout_error.empty()) {
    std::cerr << "svms detect: " << stdout_error << "; the results are lost\n";
    return kExitFailed;
  }
  if (unopenable_video) return kExitBadInput;
  return failed ? kExitFailed : kExitOk;
}

}  // namespace

void AddDetectCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<DetectOptions>();
  CLI::App* det = app.add_subcommand("detect", "Find, identify and measure markers in images");
  det->add_option("IMAGES", o->inputs, "Image files, directories, globs or video files")
      ->required();
  det->add_option("--camera", o->camera,
                  "mrcal .cameramodel: enables poses and undistorted corner fits");
  det->add_option("--markers", o->markers,
                  "Marker models (svms.marker, svms.markers or svms.layout)");
  det->add_option("--overlay", o->overlay,
                  "Write overlay PNGs (outline, tip star, ID) to this directory");
  det->add_option("--threads", o->threads, "Images processed in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  det->add_option("--max-megapixels", o->max_megapixels,
                  "Refuse larger images (checked from the file header, before decoding)")
      ->check(CLI::Range(1e-6, 1e5))
      ->capture_default_str();
  det->add_option("--debug", o->debug,
                  "Write each step's picture of the last image to this directory");
  AddPhotometryOptions(det, &o->photometry);
  det->add_flag("--json", o->json, "JSON Lines output (the only format; accepted for clarity)");
  det->add_flag("--quiet", o->quiet, "No progress on stderr");
  det->footer(
      "Output: one JSON line per image: image, ms, detections (id, corners TL/TR/BR/BL as "
      "printed,\n"
      "corner_sigma (each corner's sigma in px from its line fits), penumbra_sides (where any:\n"
      "the sides, 0-3 from corner k to k + 1, found under a shadow's penumbra), tip (px), "
      "tip_sigma (px, each "
      "axis), bit_errors, "
      "cam_from_marker {rvec, tvec}, covariance (36 numbers, row-major,\n"
      "[rotation, translation] in camera axes), pose_ambiguous (and then alternative_pose\n"
      "{rvec, tvec, weight}: the other planar pose and its share of the likelihood),\n"
      "calibration_in_covariance (the\n"
      "covariance includes the calibration's uncertainty: CAMERA.covariance.json was next to the\n"
      "camera model), pose_error (with --camera, why a detection has no pose), nested_in),\n"
      "photometry {response, black_level, white_level, bayer, source}: how the pixels were\n"
      "turned into linear light before measuring (option, camera, image or default).\n"
      "A video file (.mp4 .mkv .avi .mov ...) gives one line per frame with frame and timestamp\n"
      "(seconds, from the container), read on one thread.\n"
      "Without --camera: IDs and corners only. A path that is not valid UTF-8 is written with\n"
      "U+FFFD for its bad bytes and its exact bytes in image_hex.\n"
      "A bad image gets an \"error\" field and a line on stderr; the batch goes on; exit code 1.\n"
      "Output files (overlays, debug pictures) never replace an input, and are written whole\n"
      "or not at all; a failed write is exit code 1.\n"
      "Examples:\n"
      "  svms detect frame.png\n"
      "  svms detect out/mockup --camera out/mockup/true.cameramodel --markers "
      "out/mockup/true_layout.json --overlay out/ov");
  det->callback([o, exit_code] { *exit_code = RunDetect(*o); });
}

}  // namespace svms::cli
