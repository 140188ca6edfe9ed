// The comparison benchmark (`svms bench compare`): SVMS against AprilTag 3 (tag36h11) and
// OpenCV ArUco (DICT_6X6_1000) on the same rendered scenes, and the paper's Fig. 9 analogue
// (range and orientation error of the 0.432 m dual marker from 0.8 to 16 m). Writes CSV and
// JSON, gnuplot plots (PNG and SVG) and report.md to options.out. Scenes:
// peers/svms/peers/compare_scenes.h; scoring: compare_metrics.h; peers: peer_tags.h,
// peer_detectors.h, peer_pose.h.
#pragma once

#include <cstdint>
#include <string>

#include "svms/peers/compare_scenes.h"

namespace svms {

struct CompareBenchmarkOptions {
  std::string out;     // the output directory
  bool quick = false;  // a few views per sweep (a smoke test)
  uint64_t seed = 1;   // of every scene and of the noise
  int size_views = 8;  // views per marker size in the size sweep
  // The SVMS post's height as a fraction of the black square's side.
  double post_height = CompareOptions{}.post_height_fraction;
  int edge_rays = CompareOptions{}.edge_rays_per_pixel;  // rays per edge pixel (0: off)
  int threads = 2;           // rendering only; every detector runs on one core
  bool save_images = false;  // also write every rendered sweep image
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 1 when a
// scene or a plot failed or an output could not be written, 2 for an unusable output
// directory; progress and messages on stderr ("svms bench compare: ..."), report.md on stdout.
int RunCompareBenchmark(const CompareBenchmarkOptions& options);

}  // namespace svms
