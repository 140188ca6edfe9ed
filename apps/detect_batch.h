// The work of `svms detect`: every image file, and every frame of every video, of the inputs
// detected and written as one JSON line on standard output, in input order.
#pragma once

#include <algorithm>
#include <string>
#include <thread>
#include <vector>

#include "svms/imageio/image_io.h"
#include "svms/pipelines/photometry.h"

namespace svms::cli {

struct DetectOptions {
  std::vector<std::string> inputs;  // image files, directories, globs or video files
  std::string camera, markers;      // "" = none
  std::string overlay, debug;       // output directories ("" = none)
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int frame_threads = 1;  // threads sharing one image (DetectorOptions::threads)
  int decimate = 1;       // steps 1-4 on N x N block averages (DetectorOptions::decimate)
  double max_megapixels = kDefaultMaxImagePixels / 1e6;
  PhotometryOptions photometry;
  bool quiet = false;
  bool json = true;
};

// Runs the batch. Returns the exit code (commands.h): 2 for bad input found before any work
// (or a video that cannot be opened), 1 when an input failed or standard output could not be
// written. A failed image gets an "error" field in its line and a line on stderr.
int RunDetect(const DetectOptions& options);

}  // namespace svms::cli
