// The JSON lines `svms detect` and `svms pose` print (docs/flight-interface.md): a detection
// with its pose and covariance, and a frame's fused object pose.
#pragma once

#include <nlohmann/json.hpp>

#include "svms/detect/detector.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/fusion/rig_pose_estimator.h"

namespace svms::cli {

// One detection of `svms detect`: id, corners, corner_sigma, penumbra_sides, tip, tip_sigma,
// bit_errors, and with a pose cam_from_marker {rvec, tvec}, covariance (36, row-major,
// [rotation, translation] in camera axes), pose_ambiguous, alternative_pose,
// calibration_in_covariance; pose_error and nested_in where they apply.
nlohmann::json DetectionJson(const Detection& d);

// One frame of `svms pose` as its JSON line: the pose of the estimator's layout `object`
// (FrameResult::object), with the frame's timing and flags.
nlohmann::json FrameJson(const FrameResult& frame, size_t object = 0);

// One time stamp of `svms pose --rig` as its JSON line: the rig_from_object of the estimator's
// layout `object` {rvec, tvec, quaternion}, its covariance (36, row-major, [rotation,
// translation], rotation about the RIG axes), and per camera (by name, the rig's order) the
// marker IDs it contributed, rejected and detected, and that camera's own valid flag.
nlohmann::json RigFrameJson(const RigFrameResult& frame, const CameraRig& rig, size_t object = 0);

}  // namespace svms::cli
