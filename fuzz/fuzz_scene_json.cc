// libFuzzer target: scene JSON (svms/sim/scene.h), parsed with no base directory (file references
// resolve against the working directory). Whatever parses must write back to JSON that parses.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "svms/sim/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  svms::Scene scene;
  if (!svms::ParseSceneJson(text, "fuzz.json", "", &scene).ok()) return 0;
  svms::Scene back;
  const svms::Status s = svms::ParseSceneJson(svms::SceneToJson(scene), "written.json", "", &back);
  if (!s.ok()) {
    std::fprintf(stderr, "written scene does not parse back: %s\n", s.message().c_str());
    std::abort();
  }
  return 0;
}
