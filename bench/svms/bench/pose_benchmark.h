// The fused-pose benchmark (`svms bench pose`): the fused object pose (fusion/) along the
// rendered approach path, with the layout surveyed by the survey pipeline on the rendered
// mockup: error against truth, NEES, fused vs best single marker, latency on one core, and a
// long run for memory and latency stability. Writes frames.csv, soak.csv, latency.csv,
// summary.json, plots and report.md to options.out.
#pragma once

#include <string>

#include "svms/fusion/object_pose.h"

namespace svms {

struct PoseBenchmarkOptions {
  std::string out;     // the output directory
  std::string data;    // a rendered approach dataset to reuse ("" = render one into OUT/approach)
  std::string mockup;  // a rendered mockup dataset to survey ("" = render one into OUT/mockup)
  std::string layout;  // a surveyed layout to use instead of surveying
  std::string camera;  // the camera for the survey and the pose ("" = the dataset's true one)
  bool quick = false;  // the quick approach and mockup, 2 passes
  // A sensor profile (scene.h) the approach and mockup are rendered through when rendered
  // here; "" = linear 8-bit PNG. A given --data is read as its truth.json's photometry says.
  std::string profile;
  int repeat = 20;  // passes over the approach for the long run (500 x 20 = 10,000 frames)
  int threads = 2;  // rendering and the survey only; the pose runs on one thread
  // The dataset's object whose cam_from_object is the truth (truth.json), and the marker whose
  // pose in both the layout and the dataset's true_layout.json ties their object frames
  // together: the approach's module and marker 10; the range set's plate and its dual marker 1.
  std::string object = "module";
  int reference = 10;
  // The fusion's corner noise model (object_pose.h).
  double corner_sigma_px = ObjectPoseOptions{}.corner_sigma_px;
  double corner_sigma_exponent = ObjectPoseOptions{}.corner_sigma_exponent;
  double variance_prior_dof = ObjectPoseOptions{}.variance_prior_dof;
  double corner_fit_scale = 0;  // 0: the model's own (CornerFitScale, object_pose.h)
  double min_corner_sigma_px = ObjectPoseOptions{}.min_corner_sigma_px;
  double corner_sigma_systematic_px = ObjectPoseOptions{}.corner_sigma_systematic_px;
  bool size_model = false;          // corner sigma from the marker's size only
  bool correlated_corners = false;  // whiten with the line fits' corner covariance
  double min_tip_sigma_px = ObjectPoseOptions{}.min_tip_sigma_px;
  bool no_calibration_covariance = false;  // leave the calibration's uncertainty out
  // The fused pose of one marker is its detector pose with the stripe and decal edges
  // (ObjectPoseOptions::use_marker_pose_with_edges); false: the refit over corners and tip.
  bool no_marker_pose_with_edges = false;
  // Leave every marker's stripe and decal edges out of the fit (ObjectPoseOptions::use_edges);
  // with no_marker_pose_with_edges: the fused pose from corners and tips only.
  bool no_edges = false;
  // Also render the approach through a two-camera rig (narrow 20 deg + wide 60 deg, 0.5 m
  // apart; pose_rig_benchmark.h) and compare its fused pose with each camera's alone.
  bool rig = false;
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 2 for
// unusable inputs (a camera for another image size, a missing reference marker), 1 when a
// dataset or the survey failed or an output could not be written; report.md also on stdout.
int RunPoseBenchmark(const PoseBenchmarkOptions& options);

}  // namespace svms
