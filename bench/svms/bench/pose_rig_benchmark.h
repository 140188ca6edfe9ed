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
};

struct RigFindings {
  std::vector<RigFrameRow> rows;
  std::string dir;  // where the rig's frames and port.rig are
};

// Renders the rig's two cameras' frames of the approach in `approach_dir` into OUT/rig (kept and
// reused when OUT/rig/port.rig exists), estimates every frame pair on this thread with
// `options` and the layouts of `layout_path`, and compares with `truth` (the approach camera's
// cam_from_object per view, which is rig_from_object). kExitOk to go on.
int RunRigApproach(const PoseBenchmarkOptions& o, const std::string& approach_dir,
                   const std::string& layout_path, const PoseEstimatorOptions& options,
                   const std::vector<std::pair<std::string, Pose>>& truth, RigFindings* f);

// rig_frames.csv in OUT, and the report's section on the rig (markdown); *met says whether its
// targets hold: the rig no worse than the better camera alone in every range bin, its mean NEES
// in the chi-square(6) 95 % band with >= 90 % of frames below 12.59, and its median latency at
// most twice `one_camera_latency_ms` (the approach's median with one camera, same run).
std::string RigReport(const PoseBenchmarkOptions& o, const RigFindings& f,
                      double one_camera_latency_ms, bool* met);

}  // namespace svms
