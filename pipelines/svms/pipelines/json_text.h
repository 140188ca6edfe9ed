// JSON text that cannot fail on the bytes of a path: Linux paths are bytes, JSON strings are
// UTF-8 (docs/conventions.md, the path fields).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace svms {

// JSON text of `j` (indent < 0: one line). Strings that are not valid UTF-8 (only paths can
// be: Linux paths are bytes) have each invalid byte replaced by U+FFFD instead of making
// nlohmann throw; SetPath keeps the exact bytes beside them.
std::string DumpJson(const nlohmann::json& j, int indent = -1);

// Sets j[key] to `path`. A path that is not valid UTF-8 is written with U+FFFD for its invalid
// bytes, and j[key + "_hex"] carries its exact bytes as lowercase hex, so that a reader
// recovers the file name (Python: bytes.fromhex(line["image_hex"]) if "image_hex" in line
// else os.fsencode(line["image"])).
void SetPath(nlohmann::json& j, const std::string& key, const std::string& path);

}  // namespace svms
