// libFuzzer target: marker model, marker set and layout JSON (svms/marker/model_io.h).
// Property checked beyond "no crash": whatever parses writes back to JSON that parses to the
// same text (the writers and the parser agree, so `svms survey` output is always readable).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "svms/marker/model_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  svms::ModelFile f;
  if (!svms::ParseModelJson(text, "fuzz.json", &f).ok()) return 0;
  (void)f.Summary();
  std::string written;
  switch (f.kind) {
    case svms::ModelFile::Kind::kMarker:
      written = svms::MarkerModelToJson(f.markers.front());
      break;
    case svms::ModelFile::Kind::kMarkerSet:
      written = svms::MarkerSetToJson(f.markers);
      break;
    case svms::ModelFile::Kind::kLayout:
      written = svms::LayoutToJson(f.layout);
      break;
  }
  svms::ModelFile back;
  const svms::Status s = svms::ParseModelJson(written, "written.json", &back);
  if (!s.ok()) {
    std::fprintf(stderr, "written JSON does not parse back: %s\n%s\n", s.message().c_str(),
                 written.c_str());
    std::abort();
  }
  return 0;
}
