// What the benchmarks read of a rendered dataset's truth (truth.json, docs/simulator.md), and
// the viewing angle they bin markers by.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "svms/base/status.h"
#include "svms/geometry/pose.h"

namespace svms {

// From a truth.json: every view's name and the cam_from_object of the object named `object`.
// Errors name the file and what is missing.
Status ReadTruthPoses(const std::string& truth_json, const std::string& object,
                      std::vector<std::pair<std::string, Pose>>* out);

// The angle between a marker's normal and the direction from it to the camera, degrees.
double ViewAngleDeg(const Pose& cam_from_marker);

}  // namespace svms
