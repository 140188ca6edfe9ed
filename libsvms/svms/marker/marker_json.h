// Internal: a marker model as a JSON object, shared by model files (model_io.h) and scene
// files. Not installed.
#pragma once

#include "svms/base/json_fields.h"
#include "svms/marker/marker_model.h"

namespace svms::json_fields {

// A marker model object (with "type" allowed only at the top level of a file).
MarkerModel ParseMarker(const json& j, const std::string& path, bool top_level);
json MarkerJson(const MarkerModel& m);

}  // namespace svms::json_fields
