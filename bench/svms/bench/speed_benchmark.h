// The speed benchmark on real photographs (`svms bench speed`): marker-free crops of real
// photographs (speed_photos.h: 1024 x 1024 and 640 x 480, grey, linear light), and the same
// crops with markers 12-200 px rendered into them by the simulator (the crop as the scene's
// image background; SVMS markers for svms, each peer's own tags for the peers). Every image
// goes through svms and the peers (AprilTag 3 decimate 2 and 1, ArUco with sub-pixel corners
// and in ArUco3 mode) on one thread, interleaved in one run (the order rotated per image),
// through svms under a per-frame deadline of 5 and 10 ms, and through svms on two threads per
// frame (svms_t2: DetectorOptions::threads, its speed-up over one thread per image). Each system
// detects and locates corners only: no pose. Writes report.md, summary.json, images.csv,
// markers.csv, the distribution plot speed_times.png/.svg and its data to options.out.
#pragma once

#include <cstdint>
#include <string>

namespace svms {

struct SpeedBenchmarkOptions {
  std::string out;         // the output directory
  bool quick = false;      // two photographs per source, one crop per size (a smoke test, < 60 s)
  uint64_t seed = 1;       // of the crops' positions and of the rendered markers and noise
  int crops_per_size = 2;  // crops of each size per photograph (one when it fits only once)
  int threads = 2;         // rendering only; every detector runs on one core (svms_t2 on two)
  // Where the photographs' packages install them: "" is the file system itself; a test lays
  // out a tree under another root.
  std::string photo_root;
  bool save_images = false;  // also write every image the detectors see (DIR/images/)
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 2 when
// no photograph was found (one line naming the packages) or the output directory is unusable,
// 1 when an output could not be written. Progress on stderr ("svms bench speed: ..."),
// report.md on stdout.
int RunSpeedBenchmark(const SpeedBenchmarkOptions& options);

}  // namespace svms
