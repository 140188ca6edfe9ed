// The detector's benchmark (`svms bench detect`): its targets measured on the simulator's
// datasets.
//
// Each set is generated, rendered in memory and detected view by view; every marker of every
// view is scored against the renderer's geometric truth. Writes to options.out:
//   markers.csv   one row per marker per view (truth, found?, errors)
//   views.csv     one row per view (time, detections, false positives)
//   summary.json  the figures of report.md, machine-readable
//   report.md     the tables and plots (docs/benchmarks.md takes it as it is)
//   *.png/svg/gp  plots; misses/ overlays of the views where something was missed or wrong
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace svms {

struct DetectBenchmarkOptions {
  std::string out;     // the output directory
  bool quick = false;  // a few views per set (a smoke test)
  uint64_t seed = 1;   // of the datasets and of the sensor noise
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::string> sets;  // DetectBenchmarkSets() to run; empty: all
  int max_miss_images = 40;       // overlays written into misses/ at most
};

// The sets, in the order they run: range, angle, sun, occlusion, clutter, noisefree,
// noisefree_range.
std::vector<std::string> DetectBenchmarkSets();

// Runs the benchmark and writes every output. Returns an exit code (exit_codes.h): 3 when a
// target was missed, 1 when a set failed or an output could not be written; messages on stderr
// ("svms bench detect: ..."), the verdict on stdout.
int RunDetectBenchmark(const DetectBenchmarkOptions& options);

}  // namespace svms
