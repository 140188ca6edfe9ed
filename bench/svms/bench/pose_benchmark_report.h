// The fused-pose benchmark's findings and outputs (pose_benchmark.h): per frame against the
// truth, the long run, and the files, plots and report.md made of them.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "svms/bench/pose_benchmark.h"
#include "svms/bench/pose_rig_benchmark.h"
#include "svms/calib/frame_alignment.h"

namespace svms {

// The range bins of the benchmark's tables (metres, [lo, hi)): the approach runs 12.9 -> 1.3 m,
// the range set 0.8 -> 16 m; the last but one holds 16 m.
inline constexpr double kPoseRangeEdgesM[] = {0, 1, 1.5, 2, 3, 4, 6, 8, 10, 12, 14, 15, 17, 1e9};

// One frame of the approach: the fused pose against the truth, and the best single marker's.
struct FrameRow {
  std::string name;
  double range = 0;
  bool valid = false;
  int markers = 0, rejected = 0;
  Eigen::Matrix<double, 6, 1> error = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> sigma = Eigen::Matrix<double, 6, 1>::Zero();
  double nees = std::nan("");
  double nees_without_calibration = std::nan("");  // the same pose without the calibration term
  // The fused pose's covariance and the share of it common to every frame (ObjectPose::
  // bias_factor; no columns without a calibration's or extrinsics' covariance).
  PoseCovariance covariance = PoseCovariance::Zero();
  Eigen::Matrix<double, 6, Eigen::Dynamic> bias_factor;
  // With a given camera: against the truth carried into its frame (AlignCameraFrames).
  double aligned_nees = std::nan(""), aligned_position_mm = std::nan(""),
         aligned_orientation_deg = std::nan("");
  double position_mm = 0, orientation_deg = 0;
  double single_position_mm = std::nan(""), single_orientation_deg = std::nan("");
  // The fused pose's range (distance camera-object) minus the truth's, mm.
  double range_error_mm = std::nan("");
  // svms detect's best single-marker pose (the smallest predicted position sigma, with the
  // stripe and decal edges where its fit used them; ObjectPoseFromMarker) against the truth.
  double detect_position_mm = std::nan(""), detect_orientation_deg = std::nan(""),
         detect_range_error_mm = std::nan("");
  bool detect_edges = false;      // that marker's pose used the edges
  bool from_marker_pose = false;  // the fused pose is the one marker's own (ObjectPose)
  double latency_ms = 0;
  double chi2 = 0;
  int dof = 0;
  bool budget_exceeded = false;
};

// What the run measured.
struct PoseFindings {
  std::vector<FrameRow> rows;                  // every frame once, in order
  std::vector<double> latency;                 // the long run, ms per frame
  std::vector<std::pair<size_t, double>> rss;  // the long run: frames, resident MiB
  // With a given camera: its frame against the true camera's (frame_alignment.h), or why it
  // could not be aligned.
  bool aligned = false;
  FrameAlignment alignment;
  std::string not_aligned;
  bool calibration_in_covariance = false;  // the camera's calibration uncertainty was used
  std::string lensmodel;                   // of the camera the poses were computed with
  // How the frames were turned into linear light (PhotometricToJson), "" = taken as stored.
  std::string photometry;
  RigFindings rig;  // with --rig: the two-camera rig along the same approach
};

// Writes frames.csv, soak.csv, latency.csv, summary.json, the plots and report.md (also on
// stdout); returns the benchmark's exit code (exit_codes.h).
int WritePoseBenchmarkReport(const PoseBenchmarkOptions& options, const PoseFindings& findings);

}  // namespace svms
