#include "svms/camera/camera_json.h"

namespace svms::json_fields {

json CameraJson(const CameraModel& c) {
  return {{"lensmodel", c.lensmodel()},
          {"intrinsics", c.intrinsics()},
          {"width", c.width()},
          {"height", c.height()}};
}

}  // namespace svms::json_fields
