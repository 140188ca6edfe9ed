// Reading and writing the JSON files that describe markers: a single marker model
// ("type": "svms.marker"), a set of models ("svms.markers") and a layout ("svms.layout").
// The format is documented in docs/markers.md. Unknown fields are errors (a misspelt field
// must not be silently ignored); nothing is defaulted.
#pragma once

#include <string>
#include <vector>

#include "svms/base/file_io.h"  // ReadTextFile, WriteTextFile (for the parsers' callers)
#include "svms/base/status.h"
#include "svms/marker/layout.h"
#include "svms/marker/marker_model.h"

namespace svms {

struct ModelFile {
  enum class Kind { kMarker, kMarkerSet, kLayout };
  Kind kind = Kind::kMarker;
  std::vector<MarkerModel> markers;  // every marker in the file (for a layout: its entries')
  Layout layout;                     // only for kLayout
  std::string Summary() const;       // one line, without the file name
};

// Parses and validates. Errors read "<source>: <field path>: expected ..., got ...".
Status ParseModelJson(const std::string& text, const std::string& source, ModelFile* out);
Status ReadModelFile(const std::string& path, ModelFile* out);

// Pretty-printed JSON (2-space indent, full double precision, trailing newline).
std::string MarkerModelToJson(const MarkerModel& model);
std::string MarkerSetToJson(const std::vector<MarkerModel>& models);
std::string LayoutToJson(const Layout& layout);

}  // namespace svms
