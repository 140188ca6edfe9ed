// A standard simulated dataset (datasets/datasets.h) written to a directory: its companion
// files, each scene's JSON and, unless asked not to, every view rendered (render_scene.h).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <thread>

namespace svms {

struct DatasetRunOptions {
  std::string name;     // the dataset (DatasetNames())
  std::string out;      // the directory
  std::string profile;  // a sensor profile (scene.h) for every scene; "" = the dataset's own
  uint64_t seed = 1;
  bool quick = false;      // a small subset of the views
  bool no_render = false;  // only the scenes and the companion files
  bool quiet = false;      // no progress on stderr
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

// Writes the dataset as one group of files, committed when every file is complete: a failure
// leaves an earlier dataset in the directory as it was. Returns an exit code (exit_codes.h);
// messages on stderr ("svms dataset: ..."), and one "wrote FILE" line per file on stdout.
int RunDataset(const DatasetRunOptions& options);

}  // namespace svms
