// The sensor-profile benchmark (`svms bench profiles`): the detector on the pixels real cameras
// deliver, every sensor profile side by side in one run.
//
// Each view of the range and angle sets is rendered once (radiance); each profile then exposes
// it through its own camera pipeline (scene.h: response, bits, black level, Bayer mosaic,
// defocus) and its own codec (libjpeg for JPEG, render.h ThroughCodec), and the image is
// turned back into linear light as a reader with the camera's photometric file would
// (photometric.h LinearizeImage) before detection. Every marker is scored against the
// renderer's truth: detection rate by size, the corners' bias along their outward diagonal
// and RMS, the single-marker pose's orientation error and NEES. The angle set is also rendered
// on a textured (Earth) background to time black-background frames against textured ones; the
// noise the detector estimates on 16-bit images is compared with the sensor's. Writes
// markers.csv, summary.json and report.md to options.out.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace svms {

struct ProfilesBenchmarkOptions {
  std::string out;     // the output directory
  bool quick = false;  // the datasets' quick subsets
  uint64_t seed = 1;   // of the datasets
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::string> profiles;  // the sensor profiles to run (scene.h); empty: every one
  // The single-marker pose whitens the corners with their joint covariance where the detector
  // gives one (MarkerPoseOptions::corner_covariance_from_fit).
  bool correlated_corners = false;
  // The single-marker pose's corner sigma: this times the line fits' sigma (with
  // correlated_corners the joint covariance's scale as well). 0: the defaults, kCornerFitScale
  // (kCornerCovarianceScale for the joint covariance; marker_pose.h).
  double corner_fit_scale = 0;
  // DetectorOptions::decimate: steps 1-4 on N x N block averages, to see what a faster search
  // loses on each profile (the targets are judged as for the defaults). In [1, kMaxDecimate]:
  // another value ends the run before it starts (exit 2).
  int decimate = 1;
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 2 for an
// unknown profile or an unusable output directory, 1 when a set failed or an output could not be
// written; report.md also on stdout.
int RunProfilesBenchmark(const ProfilesBenchmarkOptions& options);

}  // namespace svms
