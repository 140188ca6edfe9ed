#include "rig_pose_stream.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_io.h"
#include "json_lines.h"
#include "svms/base/file_io.h"
#include "svms/fusion/rig_pose_estimator.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/json_text.h"

namespace svms::cli {

bool ParseFramesListLine(const std::string& line, size_t cameras, const std::filesystem::path& base,
                         double* timestamp, std::vector<std::string>* paths, std::string* error) {
  std::istringstream in(line);
  std::vector<std::string> fields;
  for (std::string f; in >> f;) fields.push_back(f);
  size_t first = 0;
  if (fields.size() == cameras + 1) {
    char* end = nullptr;
    const double t = std::strtod(fields[0].c_str(), &end);
    if (!end || *end != '\0' || !std::isfinite(t)) {
      *error = "expected a time stamp (seconds) before the " + std::to_string(cameras) +
               " images, got '" + fields[0] + "'";
      return false;
    }
    *timestamp = t;
    first = 1;
  } else if (fields.size() != cameras) {
    *error = "expected [TIMESTAMP] and " + std::to_string(cameras) +
             " images (one per camera of the rig, '-' for none), got " +
             std::to_string(fields.size()) + " fields";
    return false;
  }
  paths->clear();
  for (size_t i = first; i < fields.size(); ++i) {
    const std::filesystem::path p(fields[i]);
    paths->push_back(fields[i] == "-" ? "" : p.is_absolute() ? fields[i] : (base / p).string());
  }
  return true;
}

int RunRigPose(const RigPoseOptions& o) {
  if (o.layouts.empty()) return BadInput("svms pose", "--layout: expected a layout file");
  if (o.frames_list.empty())
    return BadInput("svms pose",
                    "--rig: expected --frames-list FILE (one line per time stamp, one image per "
                    "camera)");
  PoseEstimatorOptions options;
  if (o.corner_sigma_px > 0) options.fusion.corner_sigma_px = o.corner_sigma_px;
  options.budget_ms = o.budget_ms;
  options.detector.threads = o.frame_threads;
  options.detector.decimate = o.decimate;
  options.detector.known_ids_only = true;
  std::unique_ptr<RigPoseEstimator> est;
  if (Status s = RigPoseEstimator::CreateFromFiles(o.rig, o.layouts, options, &est); !s)
    return BadInput("svms pose", s.message());
  std::string list;
  if (Status s = ReadTextFile(o.frames_list, &list); !s) return BadInput("svms pose", s.message());
  const std::filesystem::path base = std::filesystem::path(o.frames_list).parent_path();
  const int64_t max_pixels = static_cast<int64_t>(o.max_megapixels * 1e6);
  const size_t n = est->num_cameras(), objects = o.layouts.size();
  std::istringstream lines(list);
  std::string line, first_error, stdout_error;
  size_t line_number = 0, index = 0, failed = 0, valid = 0;
  RigFrameResult r;
  std::vector<cv::Mat> frames(n);
  std::vector<std::string> paths;
  while (stdout_error.empty() && std::getline(lines, line)) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    double timestamp = static_cast<double>(index);
    std::string error;
    if (!ParseFramesListLine(line, n, base, &timestamp, &paths, &error)) {
      error = o.frames_list + ", line " + std::to_string(line_number) + ": " + error;
    } else {
      for (size_t c = 0; c < n && error.empty(); ++c) {
        frames[c].release();
        if (paths[c].empty()) continue;
        const CameraModel& camera = est->camera(c).camera();
        if (Status s = LoadImage(paths[c], max_pixels, &frames[c]); !s)
          error = s.message();
        else if (frames[c].cols != camera.width() || frames[c].rows != camera.height())
          error = paths[c] + ": " + std::to_string(frames[c].cols) + "x" +
                  std::to_string(frames[c].rows) + " pixels, but camera '" +
                  est->rig().cameras[c].name + "' is " + std::to_string(camera.width()) + "x" +
                  std::to_string(camera.height());
      }
    }
    if (error.empty()) est->Estimate(frames, timestamp, &r);
    std::string text;
    bool any_valid = false;
    for (size_t i = 0; i < objects; ++i) {
      nlohmann::json j;
      if (error.empty()) {
        j = RigFrameJson(r, est->rig(), i);
        any_valid |= r.object(i).valid;
      } else {
        j = {{"timestamp", timestamp}, {"valid", false}, {"error", error}};
      }
      j["line"] = line_number;
      nlohmann::json images = nlohmann::json::array();
      for (const std::string& p : paths)
        images.push_back(p.empty() ? nlohmann::json() : nlohmann::json(p));
      j["images"] = images;
      if (objects > 1) SetPath(j, "layout", o.layouts[i]);
      text += DumpJson(j) + "\n";
    }
    valid += any_valid;
    if (!error.empty()) {
      std::cerr << "svms pose: " << error << "\n";
      if (first_error.empty()) first_error = error;
      ++failed;
    }
    WriteStdout(text, true, &stdout_error);
    ++index;
  }
  if (!o.quiet)
    std::cerr << "svms pose: " << index << " time stamps, " << valid << " with a pose, " << failed
              << " failed\n";
  if (!stdout_error.empty()) {
    std::cerr << "svms pose: " << stdout_error << "\n";
    return kExitFailed;
  }
  if (failed) {
    std::cerr << "svms pose: " << failed << " of " << index
              << " lines failed (first: " << first_error << ")\n";
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace svms::cli
