// The calibration benchmark (`svms bench calibrate`): calibration accuracy on the simulator's
// calibration dataset, whose true camera is known. (a) svms calibrate on the SVMS board; (b)
// mrcal's own optimizer (mrcal-calibrate-cameras) on a chessboard rendered with the same camera
// and poses, corners by OpenCV's findChessboardCornersSB; (c) OpenCV's calibrateCamera on the
// same corners. For each: the projection error against the true camera over the image, and the
// tool's own predicted uncertainty. Writes data/, CSV, JSON, plots and report.md to
// options.out.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <thread>

namespace svms {

struct CalibrateBenchmarkOptions {
  std::string out;     // the output directory (the rendered views are kept in OUT/data/)
  bool quick = false;  // the first 12 views only (a smoke test)
  uint64_t seed = 1;   // the calibration dataset's (views and noise)
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 1 when a
// tool failed or an output could not be written; messages on stderr ("svms bench calibrate:
// ..."), a summary per tool on stdout.
int RunCalibrateBenchmark(const CalibrateBenchmarkOptions& options);

}  // namespace svms
