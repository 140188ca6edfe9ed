// Small pieces the `svms bench` reports share: number formatting, the mean, and the
// true poses of a rendered dataset.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "svms/base/format.h"
#include "svms/base/status.h"
#include "svms/geometry/pose.h"

namespace svms::cli {

using svms::Fixed;  // `v` with `digits` decimals (svms/base/format.h)
// The mean of `v`; NaN when empty.
double Mean(const std::vector<double>& v);

// The angle between a marker's normal and the direction from it to the camera, degrees.
double ViewAngleDeg(const Pose& cam_from_marker);

// From a truth.json (docs/simulator.md): every view's name and the cam_from_object of the
// object named `object`. Errors name the file and what is missing.
Status ReadTruthPoses(const std::string& truth_json, const std::string& object,
                      std::vector<std::pair<std::string, Pose>>* out);

}  // namespace svms::cli
