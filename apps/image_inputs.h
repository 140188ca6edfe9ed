// Image inputs on the command line: the one expansion of IMAGE | DIR | GLOB that every
// subcommand taking images uses (detect, calibrate, survey).
#pragma once

#include <string>
#include <vector>

namespace svms::cli {

// True when `path`'s extension (any case) is one of the image types the CLI reads:
// .png .jpg .jpeg .tif .tiff .bmp .pgm .ppm.
bool IsImageFile(const std::string& path);

// Expands each input in order: a directory gives its image files (IsImageFile), sorted by name;
// a name with a glob character (*?[) gives its matches in glob order; anything else, and a glob
// that matches nothing, is kept as given (so that it fails to read later, named).
std::vector<std::string> ExpandImageInputs(const std::vector<std::string>& inputs);

}  // namespace svms::cli
