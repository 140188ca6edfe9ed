// The work of `svms pose --rig`: the fused rig_from_object of every time stamp of a camera rig,
// from a frames list (one line per time stamp, one image per camera), streamed as one flushed
// JSON line per time stamp (per object with several layouts).
//
// Frames list (--frames-list FILE): one time stamp per line, "[TIMESTAMP] IMAGE_0 ... IMAGE_N-1"
// separated by spaces or tabs, one image per camera in the rig file's order; a leading number is
// the time stamp (seconds) when the line has N + 1 fields, else the line index is. "-" for a
// camera without a frame at that time. Relative paths are relative to the list's folder. Empty
// lines and lines starting with '#' are skipped.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace svms::cli {

struct RigPoseOptions {
  std::string rig, frames_list;
  std::vector<std::string> layouts;
  double corner_sigma_px = 0;  // 0: the default (ObjectPoseOptions)
  double budget_ms = 0;        // per camera and frame; 0 = none
  int frame_threads = 1;       // threads sharing one frame (DetectorOptions::threads)
  int decimate = 1;            // steps 1-4 on N x N block averages (DetectorOptions::decimate)
  double max_megapixels = 100;
  bool quiet = false;
};

// One line of a frames list (above) split into a time stamp and one path per camera ("" for
// "-"), relative paths resolved against `base` (the list's folder). *timestamp is left as it
// is when the line has none. False with *error when the line does not fit.
bool ParseFramesListLine(const std::string& line, size_t cameras, const std::filesystem::path& base,
                         double* timestamp, std::vector<std::string>* paths, std::string* error);

// Runs the stream. Returns the exit code: 2 for bad input found before any work (rig, layouts,
// the list unreadable), 1 when a line failed (its JSON line has "error") or stdout failed.
int RunRigPose(const RigPoseOptions& options);

}  // namespace svms::cli
