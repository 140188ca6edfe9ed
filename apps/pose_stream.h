// The work of `svms pose`: the fused object pose of every frame (image files, video frames, or
// paths read from standard input), streamed as one flushed JSON line per frame.
#pragma once

#include <string>
#include <vector>

#include "svms/fusion/object_pose.h"
#include "svms/pipelines/photometry.h"

namespace svms::cli {

struct PoseOptions {
  std::vector<std::string> inputs;  // image files, directories, globs or videos
  std::string camera, overlay;      // overlay: an output directory ("" = none)
  // One layout per object; with several, each frame gives one line per object (in this order).
  std::vector<std::string> layouts;
  // Detect every ID, not only the layouts' ones, and list the markers of no layout in each line
  // (unassigned_markers).
  bool unknown_ids = false;
  bool from_stdin = false;  // frames from stdin: "PATH [TIMESTAMP]" per line
  bool quiet = false;
  double corner_sigma_px = ObjectPoseOptions{}.corner_sigma_px;
  double budget_ms = 0;   // per frame; 0 = none
  int frame_threads = 1;  // threads sharing one frame (DetectorOptions::threads)
  int decimate = 1;       // steps 1-4 on N x N block averages (DetectorOptions::decimate)
  double max_megapixels = 100;
  PhotometryOptions photometry;
};

// Runs the stream. Returns the exit code (commands.h): 2 for bad input found before any work
// (or a video that cannot be opened), 1 when a frame failed or standard output could not be
// written. A failed frame gets an "error" field in its line and a line on stderr.
int RunPose(const PoseOptions& options);

}  // namespace svms::cli
