// The work of `svms survey rig`: a camera rig's extrinsics (each camera's rig_from_cam with its
// covariance) surveyed from frames of an object whose layout is known, taken by the rig's
// cameras at common time stamps (SurveyRig, bundle/svms/bundle/rig_survey.h).
//
// Frames come as for `svms pose --rig` (rig_pose_stream.h: one line per time stamp, one image
// per camera in the rig file's order, '-' for none). Every camera's frame is detected with its
// own PoseEstimator (the rig file's camera model, covariance and photometric sidecars); the
// detections of the layout's markers are the survey's observations. The new rig file is the
// input one with every rig_from_cam and covariance replaced; the reference camera's pose (the
// gauge) and covariance are kept as given.
#pragma once

#include <string>

namespace svms::cli {

struct RigSurveyRunOptions {
  std::string rig, layout, frames_list, out, report;
  std::string reference;       // camera name; empty: the rig file's first camera
  double corner_sigma_px = 0;  // 0: the fusion's default (ObjectPoseOptions)
  double max_megapixels = 100;
  bool quiet = false;
};

// Runs the survey and writes `out` (and `report`, markdown) atomically. Returns the exit code:
// 2 for bad input (a file or field named, --out equal to an input), 1 when the survey failed or
// an output could not be written.
int RunRigSurvey(const RigSurveyRunOptions& options);

}  // namespace svms::cli
