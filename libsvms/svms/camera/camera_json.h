// Internal: a camera model as an inline JSON object, for scene and truth files and the CLI's
// reports. Not installed.
#pragma once

#include "svms/base/json_fields.h"
#include "svms/camera/camera.h"

namespace svms::json_fields {

// A camera written inline: {"lensmodel", "intrinsics", "width", "height"} (what a scene's
// "camera" field and truth.json carry).
json CameraJson(const CameraModel& camera);

}  // namespace svms::json_fields
