// The fused pose of a two-camera rig along the approach (`svms bench pose --rig`): the
// approach's scene seen by a narrow (20 degrees across) and a wide (60 degrees) 1024 x 1024
// pinhole, 0.5 m apart on a rig whose frame is the approach camera's, both turned toward a
// point 6 m ahead on its axis (fixed extrinsics, as on a vehicle). Every frame pair goes through
// one RigPoseEstimator (rig_pose_estimator.h); its rig_from_object is compared with the truth
// and with each camera's own pose of the object, by range.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "svms/bench/pose_benchmark.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/geometry/pose.h"

namespace svms {

// One time stamp of the rig: the fused pose and each camera's own, against the truth.
struct RigFrameRow {
  std::string name;
  double range = 0;  // metres, rig origin to object origin (true)
  bool valid = false;
  int markers = 0;  // used by the rig's fit, over both cameras
  double nees = std::nan("");
  double position_mm = std::nan(""), orientation_deg = std::nan("");
  // Each camera alone (its PoseEstimator's fused pose carried to the rig): narrow, wide.
  std::array<bool, 2> camera_valid{};
  std::array<int, 2> camera_markers{};
  std::array<double, 2> camera_position_mm{std::nan(""), std::nan("")};
  std::array<double, 2> camera_orientation_deg{std::nan(""), std::nan("")};
  double latency_ms = 0;  // both cameras' detection and fusion, then the rig's
  // Each camera's own detection and fusion within that call (FrameResult::latency_ms).
  std::array<double, 2> camera_latency_ms{};
};

struct RigFindings {
  std::vector<RigFrameRow> rows;
  std::string dir;    // where the rig's frames and port.rig are
  std::string error;  // why the rig was not measured ("" when it was)
};

// Renders the rig's two cameras' frames of the approach in `approach_dir` (its scene.json) into
// OUT/rig: each camera's frames in OUT/rig/NAME, its model, then source.json (what they were
// rendered from) and port.rig last. A folder with port.rig and the same source.json is reused.
// Sets f->dir. kExitOk to go on; else a line on stderr naming the file.
int PrepareRigApproach(const PoseBenchmarkOptions& o, const std::string& approach_dir,
                       RigFindings* f);

// Estimates every frame pair of f->dir on this thread (one pair in memory at a time) with
// `options` and the layout of `layout_path`, against `truth` (the approach camera's
// cam_from_object per view, which is rig_from_object: the rig frame is that camera's). A file
// that cannot be read ends the rig's part with f->error set; the rest of the benchmark goes on.
void RunRigApproach(const std::string& layout_path, const PoseEstimatorOptions& options,
                    const std::vector<std::pair<std::string, Pose>>& truth, RigFindings* f);

// rig_frames.csv in OUT, the report's section on the rig (markdown) and its figures into
// *summary; *met says whether its targets hold: the rig no worse than the better camera alone in
// every range bin (RMS over the frames where both have a pose), its mean NEES in the
// chi-square(6) 95 % band with >= 90 % of frames below 12.59, and its median latency per frame
// pair at most twice one camera's: the slower of its two cameras alone (their own medians
// within the same calls). `one_camera_latency_ms` (the approach's median with its own camera,
// one pass, same run) is reported beside them.
std::string RigReport(const PoseBenchmarkOptions& o, const RigFindings& f,
                      double one_camera_latency_ms, nlohmann::json* summary, bool* met);

}  // namespace svms
